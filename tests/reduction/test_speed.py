"""Speed: four bodies of the real size (20k-60k DOFs, 100 modes, seven static cases) < 30 s.

Slow to *build* (the synthetic bodies' modes come from sparse Lanczos, about a
minute in all), so marked ``slow``; the stage itself is what is timed.
"""

import json
import os
import time

import h5py
import pytest

from tests import synthetic_bodies as sb  # noqa: E402

from gimbal_reduction.reduction import stage  # noqa: E402


@pytest.mark.slow
def test_four_real_size_bodies_under_30_s(tmp_path):
    sizes = [(664, 5), (1000, 5), (1504, 5), (2000, 5)]  # 19.9k, 30k, 45.1k, 60k DOFs
    files = []
    for n, (n_circ, n_width) in enumerate(sizes, start=2):
        body = sb.band_body(n_circ=n_circ, n_width=n_width, body=n)
        files.append(sb.write_body_file(tmp_path / f"body{n}.h5", body))
    started = time.perf_counter()
    for n, path in enumerate(files, start=2):
        assert stage.main(["--body-file", str(path), "--out",
                           str(tmp_path / "reduction" / f"body{n}.h5"), "--quiet"]) == 0
    elapsed = time.perf_counter() - started
    print(f"four bodies reduced in {elapsed:.1f} s")
    assert elapsed < 30.0
    with h5py.File(tmp_path / "reduction" / "body5.h5", "r") as f:
        assert len(f["static_modes"]) == 7 and f["P"].shape == (3, 100)
        checks = json.loads(f.attrs["checks"])
        assert all(c["passed"] for c in checks), [c for c in checks if not c["passed"]]
