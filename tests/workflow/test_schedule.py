"""The rules' scheduling priorities (gimbal_reduction.workflow.schedule): the file contract, its
refusals, how the Snakefile applies it, and the committed file against the workflow's rules."""
import json
import re
from pathlib import Path
from types import SimpleNamespace

import pytest

from gimbal_reduction.workflow import schedule
from gimbal_reduction.workflow.provenance import write_json

ROOT = Path(__file__).resolve().parents[2]


def workflow_rule_names():
    """Every rule the Snakefile defines: `rule NAME:` and `use rule ... as NAME` in its files."""
    names = set()
    for path in [ROOT / "Snakefile", *sorted((ROOT / "workflow" / "rules").glob("*.smk"))]:
        text = path.read_text()
        names |= set(re.findall(r"^rule (\w+):", text, flags=re.M))
        names |= set(re.findall(r"^use rule \w+ as (\w+)", text, flags=re.M))
    return names


def test_the_committed_priorities_name_only_rules_of_the_workflow():
    priorities = schedule.read_priorities(ROOT / "workflow" / "priorities.json")
    names = workflow_rule_names()
    assert "study_scene" in names and "all" in names          # the parse finds rules at all
    assert set(priorities) <= names, sorted(set(priorities) - names)
    # the longest scene's own rules exist for a priority of their own: measured higher
    assert priorities["study_scene_first"] > priorities["study_scene"]
    assert priorities["load_ranking_first"] > priorities["load_ranking"]


def test_apply_sets_every_rule_and_reports_stale_names():
    rules = [SimpleNamespace(name="mesh", priority=3), SimpleNamespace(name="report", priority=7)]
    stale = schedule.apply(rules, {"mesh": 45, "gone": 10})
    assert [r.priority for r in rules] == [45, 0] and stale == ["gone"]


@pytest.mark.parametrize("text, culprit", [
    ("not json", "not a readable priorities file"),
    ('{"rules": {}}', "no 'priorities' mapping"),
    ('{"priorities": {"mesh": -1}}', "rule 'mesh' is -1"),
    ('{"priorities": {"mesh": 2.5}}', "rule 'mesh' is 2.5"),
    ('{"priorities": {"mesh": true}}', "rule 'mesh' is True"),
])
def test_a_bad_priorities_file_is_refused_naming_it(tmp_path, text, culprit):
    path = tmp_path / "priorities.json"
    path.write_text(text)
    with pytest.raises(schedule.ScheduleError, match=re.escape(culprit)) as err:
        schedule.read_priorities(path)
    assert str(path) in str(err.value)
    with pytest.raises(schedule.ScheduleError, match="not a readable"):
        schedule.read_priorities(tmp_path / "missing.json")


def test_written_priorities_read_back_with_their_source(tmp_path):
    path = tmp_path / "p.json"
    write_json(path, schedule.document({"b": 2, "a": 1}, {"revision": "abc"}))
    data = json.loads(path.read_text())
    assert list(data["priorities"]) == ["a", "b"] and data["source"] == {"revision": "abc"}
    assert "provenance" in data and schedule.read_priorities(path) == {"a": 1, "b": 2}


def test_the_workflow_profile_makes_the_timed_rescheduling_rare():
    """profiles/default (read by Snakemake itself) sets a job rate limit whose timespan, the
    delay of every timed re-evaluation, is seconds (not Snakemake's 1 s, not so long that the
    process lingers after its last job), and whose count this workflow never reaches."""
    import yaml
    from snakemake.settings.types import MaxJobsPerTimespan

    profile = yaml.safe_load((ROOT / "profiles" / "default" / "config.yaml").read_text())
    limit = MaxJobsPerTimespan.parse_choice(profile["max-jobs-per-timespan"])
    assert 5 <= limit.timespan <= 15 and limit.max_jobs >= 500
