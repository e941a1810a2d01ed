"""Issue 16: every output file carries versions, git revision and config hash (gimbal_reduction.workflow.provenance).

The writers one by one (each kind of file and how ``read_provenance`` reads it back), then the
study's writers run on a synthetic study (tables, findings, the scene report): every file they
leave carries a provenance record.  ``tests/workflow/test_pipeline.py`` walks the outputs of the
small end-to-end run (meshes, body, reduction, model and simulation files, mode shapes, checks).
"""
from __future__ import annotations

import csv
import json
import os

import h5py
import pytest

from gimbal_reduction.workflow import provenance as P
from gimbal_reduction.workflow.config import DEFAULT_CONFIG, load_config, section_hash

# outputs that carry none, each for a stated reason
WITHOUT = {}


def carries(path) -> bool:
    """Has the file a provenance record with a config hash, a git revision and versions?"""
    rec = P.read_provenance(path)
    return bool(rec.get("config_hash")) and bool(rec.get("git")) and "numpy" in (rec.get("versions") or {})


def walk(root):
    """Every file under root but the provenance sidecars, as paths relative to root."""
    for folder, _, files in os.walk(root):
        for name in files:
            if not name.endswith(P.SIDECAR):
                yield os.path.relpath(os.path.join(folder, name), root)


def test_record_holds_versions_git_and_config_hash():
    rec = P.provenance("abc123")
    assert rec["config_hash"] == "abc123" and rec["config_hash_from"] == "stage"
    assert rec["git"] == rec["versions"]["git"] and rec["git"] != "" and "numpy" in rec["versions"]


def test_config_hash_from_the_inputs_or_the_configuration_file(tmp_path, monkeypatch):
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    for path, h in ((a, "h-one"), (b, "h-two")):
        with h5py.File(path, "w") as f:
            f.attrs["config_hash"] = h
            f.attrs["versions"] = json.dumps(P.versions())
    assert P.provenance(sources=[a])["config_hash"] == "h-one"             # one input: its hash
    assert P.provenance(sources=[a, a])["config_hash_from"] == "2 input files"
    both = P.provenance(sources=[a, b])["config_hash"]
    assert both not in ("h-one", "h-two") and both == P.combined_hash(["h-two", "h-one"])
    monkeypatch.chdir(tmp_path)                       # no config/config.yaml here: the project's
    rec = P.provenance(sources=[tmp_path / "missing.h5"])
    assert rec["config_hash"] == section_hash(load_config(DEFAULT_CONFIG))
    assert rec["config_hash_from"].startswith("configuration file")


def test_every_kind_of_file_carries_it(tmp_path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rec = P.provenance("cafe01")
    fig = plt.figure()
    fig.gca().plot([0, 1], [1, 0])
    for name in ("f.png", "f.pdf", "f.svg"):
        P.savefig(fig, tmp_path / name, rec, dpi=40)
    plt.close(fig)
    P.write_json(tmp_path / "d.json", {"x": 1, "provenance": {"command": "c"}}, rec)
    P.write_json(tmp_path / "l.json", [1, 2], rec)
    P.write_text(tmp_path / "t.md", "# title\n\ntext", rec)
    P.write_csv(tmp_path / "t.csv", [{"a": 1.5, "b": "x"}], ["a", "b"], record=rec)
    P.write_text(tmp_path / "t.txt", "plain", rec)
    files = sorted(walk(tmp_path))
    assert files == ["d.json", "f.pdf", "f.png", "f.svg", "l.json", "t.csv", "t.md", "t.txt"]
    for name in files:
        assert P.read_provenance(tmp_path / name)["config_hash"] == "cafe01", name
        assert carries(tmp_path / name), name
    data = json.loads((tmp_path / "d.json").read_text())
    assert data["x"] == 1 and data["provenance"]["command"] == "c" and data["provenance"]["git"]
    # the CSV stays a plain table (its record in t.csv.provenance.json); the Markdown ends in a comment
    assert list(csv.DictReader(open(tmp_path / "t.csv"))) == [{"a": "1.5", "b": "x"}]
    assert (tmp_path / "t.csv.provenance.json").is_file()
    assert (tmp_path / "t.md").read_text().startswith("# title\n\ntext\n<!-- provenance: {")
    assert (tmp_path / "f.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_typst_report_pdf_carries_it(tmp_path):
    pytest.importorskip("typst")
    from gimbal_reduction.results.markup import compile_pdf
    rec = P.provenance("beef02")
    out = tmp_path / "r.pdf"
    compile_pdf('#set document(title: "x")\n= Quoted "title" (with) \\ backslash\n', str(out), str(tmp_path), rec)
    assert P.read_provenance(out)["config_hash"] == "beef02" and carries(out)
    assert P.read_provenance(tmp_path / "r.typ")["config_hash"] == "beef02"


def test_h5_files_of_both_conventions(tmp_path):
    """Body, reduction and load-ranking files: attribute versions (JSON); reduced-model and
    simulation files: version_* attributes; both with config_hash."""
    for k, attrs in enumerate(({"versions": json.dumps(P.versions())},
                               {f"version_{key}": v for key, v in P.versions().items()})):
        path = tmp_path / f"f{k}.h5"
        with h5py.File(path, "w") as f:
            f.attrs["config_hash"] = "0123abcd"
            f.attrs.update(attrs)
        assert carries(path) and P.read_provenance(path)["config_hash"] == "0123abcd"


def test_state_space_export_fields(tmp_path):
    """The .mat and .npz of gimbal_reduction.solver.dynamics.export hold the record as JSON text (field provenance)."""
    import numpy as np
    import scipy.io
    ss = {"A": np.eye(2), "provenance": json.dumps(P.provenance("feed03"), sort_keys=True)}
    scipy.io.savemat(tmp_path / "m.mat", ss, do_compression=True)
    np.savez_compressed(tmp_path / "m.npz", **ss)
    for name in ("m.mat", "m.npz"):
        assert P.read_provenance(tmp_path / name)["config_hash"] == "feed03" and carries(tmp_path / name)


def test_a_failed_write_leaves_neither_the_file_nor_its_sidecar(tmp_path):
    class Boom(Exception):
        pass

    target = tmp_path / "new" / "t.csv"
    with pytest.raises(Boom):
        with P.atomic_path(P.sidecar_path(target)) as side, P.atomic_path(target) as tmp:
            tmp.write_text("a\n")
            side.write_text("{}")
            raise Boom
    assert not (tmp_path / "new").exists()


def test_the_study_writers_outputs_carry_it(tmp_path):
    """Tables, findings and the scene report of a synthetic study: every file carries provenance,
    the tables' and findings' config hash that of the simulations they were made from."""
    from gimbal_reduction.results.study import figures, report
    from tests.results.synthetic_study import write_tables
    out = tmp_path / "out"
    truth, cases, rt, st, fj = write_tables(str(tmp_path), str(out / "tables"))
    assert figures.main(["--truth", truth, "--cases", *cases[:2], "--ranking-table", str(rt),
                         "--static-table", str(st), "--out-dir", str(out / "figures")]) == 0
    pytest.importorskip("typst")
    assert report.main(["--ranking-table", str(rt), "--static-table", str(st), "--findings", str(fj),
                        "--figures", str(out / "figures" / "figures.json"), "--truth", truth,
                        "--out", str(out / "report" / "thesis.pdf")]) == 0
    found = sorted(walk(out))
    assert {"tables/errors_ranking.csv", "tables/errors_static.csv", "tables/findings.csv",
            "tables/findings.json", "figures/figures.json", "report/thesis.pdf"} <= set(found)
    exempt = [rel for rel in found if any(rule(rel) for rule in WITHOUT.values())]
    missing = [rel for rel in found if rel not in exempt and not carries(out / rel)]
    assert not missing, missing
    sims = P.combined_hash(P.read_provenance(p)["config_hash"] for p in [truth, *cases])
    assert P.read_provenance(rt)["config_hash"] == sims


def test_other_revision_names_a_file_made_by_other_code(tmp_path):
    """A report input made at another git revision is named by its revision (the report says it
    may be stale); one made at this revision, or with none recorded, is not."""
    from gimbal_reduction.workflow.provenance import git_revision, other_revision
    now = git_revision().removesuffix("-dirty")
    for name, git, expected in (("old.json", "0000000", "0000000"), ("same.json", now + "-dirty", None),
                                ("none.json", None, None)):
        record = {"value": 1} if git is None else {"value": 1, "provenance": {"git": git}}
        (tmp_path / name).write_text(json.dumps(record))
        assert other_revision(tmp_path / name) == (expected if now != "unknown" else None), name
