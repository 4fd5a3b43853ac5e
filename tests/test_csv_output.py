"""The one CSV writer (files.csv_writer): the per-sample CSVs written by numpy in blocks (issue 37),
byte for byte what pandas' ``to_csv(index=False, float_format="%.10g")`` wrote before, on awkward
values, and atomically; the trial CSV, the live recording and ``summary.csv`` as pandas, numpy's
``savetxt`` and the csv module wrote them before (issue 45).

pandas, numpy and the csv module are the references here and only here.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

import csv
import io

from limbstiff.files import csv_writer
from limbstiff.files.csv_writer import csv_head, csv_rows, write_csv
from limbstiff.files.outputs import CURVE_CSV, STIFFNESS_CSV, round_significant, write_result


def _reference(columns) -> bytes:
    return pd.DataFrame(columns).to_csv(index=False, float_format="%.10g", lineterminator="\n").encode("utf-8")


def _awkward(n: int, seed: int) -> dict:
    rng = np.random.default_rng(seed)
    special = np.array([np.nan, np.inf, -np.inf, 0.0, -0.0, 1e-300, -1e-300, 5e-324, 1.7976931348623157e308,
                        1e300, 1e22, 1e23, 0.1, 1e-5, 1e-4, 9.9999999995e-5, 0.0001000000000049, 9999999999.5,
                        9999999999.4, 999999999.95, 1e10, 1e9, 123456789012.0, 1200.0, 100.0, 1.0, -1.0, 0.5,
                        2.5, 0.000123456789, 0.00001234567891, 1.00000000005, 1.00000000015, 12345678905.0,
                        3599.999, 3600.0, 1e-13, 1e-14, 9.999999999e31, 1e32, -5e-7, 2 ** 52 + 0.5])
    bits = rng.integers(0, 2 ** 63, n, dtype=np.int64).view(np.float64)
    return {
        "special": rng.choice(special, n),
        "bits": np.where(np.isnan(bits), 1.0, bits) * rng.choice([-1.0, 1.0], n),
        "log_uniform": rng.choice([-1.0, 1.0], n) * 10 ** rng.uniform(-20, 40, n),
        # values on the ninth to eleventh digit, where a tie at the tenth is close
        "near_ties": np.round(rng.uniform(0, 1e4, n), int(rng.integers(0, 8))) + rng.integers(0, 2, n) * 5e-7,
        "integral": rng.integers(-10 ** 12, 10 ** 12, n).astype(float),
        "five_digits": round_significant(rng.lognormal(3, 2, n), digits=5),
        "time": 3590.0 + np.arange(n) / 1000.0,
        "int64": rng.integers(-2 ** 63, 2 ** 63 - 1, n, dtype=np.int64),
        "small_int": rng.integers(-3, 2, n),
        "uint8": rng.integers(0, 256, n).astype(np.uint8),
        "flag": rng.integers(0, 2, n).astype(bool),
        "float32": (rng.standard_normal(n) * 10.0 ** rng.integers(-6, 6, n)).astype(np.float32),
    }


@pytest.mark.parametrize("seed", [0, 1])
def test_write_csv_is_pandas_byte_for_byte(tmp_path, seed):
    columns = _awkward(20000, seed)
    write_csv(tmp_path / "x.csv", columns)
    assert (tmp_path / "x.csv").read_bytes() == _reference(columns)


def test_every_value_of_a_column_of_specials_alone_and_across_blocks(tmp_path, monkeypatch):
    monkeypatch.setattr(csv_writer, "CSV_BLOCK_ROWS", 7)
    values = _awkward(500, 2)["special"]
    for columns in ({"only": values}, {"a,b": values, 'say "x"': -values, "n": np.arange(500)}):
        write_csv(tmp_path / "x.csv", columns)
        assert (tmp_path / "x.csv").read_bytes() == _reference(columns)


def test_a_lone_nan_is_quoted_and_no_rows_leave_the_header(tmp_path):
    write_csv(tmp_path / "x.csv", {"x": np.array([np.nan, 1.0, np.nan])})
    assert (tmp_path / "x.csv").read_bytes() == _reference({"x": [np.nan, 1.0, np.nan]}) == b'x\n""\n1\n""\n'
    empty = {"t": np.zeros(0), "k": np.zeros(0, dtype=int)}
    write_csv(tmp_path / "e.csv", empty)
    assert (tmp_path / "e.csv").read_bytes() == _reference(empty) == b"t,k\n"


def test_a_frame_is_written_as_its_columns(tmp_path):
    frame = pd.DataFrame(_awkward(300, 3))
    write_csv(tmp_path / "x.csv", frame)
    assert (tmp_path / "x.csv").read_bytes() == frame.to_csv(index=False, float_format="%.10g",
                                                              lineterminator="\n").encode()


def test_a_table_column_is_written_cell_by_cell_as_the_csv_module_writes_it(tmp_path):
    cells = [None, "a,b", 'say "x"', "line\nbreak", "é", 0.1, 1e16, 3, True, "", 2.5]
    rows = [{"name": c, "x": float(i)} for i, c in enumerate(cells)]
    write_csv(tmp_path / "x.csv", {"name": np.array(cells, dtype=object), "x": np.arange(len(cells), dtype=object) * 1.0})
    reference = io.StringIO()
    writer = csv.DictWriter(reference, fieldnames=["name", "x"], lineterminator="\n")
    writer.writeheader()
    writer.writerows(rows)
    assert (tmp_path / "x.csv").read_bytes() == reference.getvalue().encode("utf-8")
    write_csv(tmp_path / "one.csv", {"only": np.array(["", None, "a"], dtype=object)})
    assert (tmp_path / "one.csv").read_bytes() == b'only\n""\n""\na\n'
    with pytest.raises(TypeError, match="column 'm'"):
        write_csv(tmp_path / "y.csv", {"m": np.zeros((2, 2))})
    assert not (tmp_path / "y.csv").exists()


def test_exact_and_shortest_floats_are_numpys_and_pythons(tmp_path):
    columns = _awkward(3000, 5)
    floats = np.column_stack([columns[k] for k in ("special", "bits", "log_uniform", "near_ties", "time")])
    saved = io.StringIO()
    np.savetxt(saved, floats, fmt="%.17g", delimiter=",")
    assert csv_rows(list(floats.T), digits=17, na_rep="nan") == saved.getvalue().encode()
    frame = pd.DataFrame({k: columns[k] for k in ("special", "bits", "log_uniform", "time")})
    write_csv(tmp_path / "x.csv", frame, digits=None, metadata={"subject": "s01", "note": "two\nlines"})
    assert (tmp_path / "x.csv").read_bytes() == (b"# subject: s01\n# note: two lines\n"
                                                 + frame.to_csv(index=False, lineterminator="\n").encode())
    assert csv_head(["t", "y"], units=["s", None]) == b"t,y\ns,\n" and csv_head(["t"], units=[None]) == b"t\n"
    with pytest.raises(ValueError, match="cannot be written"):
        csv_head(["t"], metadata={"a:b": "c"})


def test_a_failure_midway_leaves_the_old_file_whole(tmp_path, monkeypatch):
    path = tmp_path / "x.csv"
    path.write_bytes(b"old\n")
    real, calls = csv_writer.csv_rows, []

    def fail_second(arrays, **kw):
        calls.append(1)
        if len(calls) == 2:
            raise RuntimeError("disk")
        return real(arrays, **kw)

    monkeypatch.setattr(csv_writer, "csv_rows", fail_second)
    monkeypatch.setattr(csv_writer, "CSV_BLOCK_ROWS", 10)
    with pytest.raises(RuntimeError):
        write_csv(path, {"t": np.arange(100.0)})
    assert path.read_bytes() == b"old\n" and [p.name for p in tmp_path.iterdir()] == ["x.csv"]


def _old_write(columns) -> bytes:
    """``stiffness.csv`` as write_result wrote it with pandas before issue 37."""
    frame = pd.DataFrame(columns)
    for column in ("stiffness", "stiffness_lo", "stiffness_hi"):
        frame[column] = round_significant(frame[column].to_numpy(), digits=5)
    return frame.to_csv(index=False, float_format="%.10g", lineterminator="\n").encode()


def test_write_result_writes_what_pandas_wrote(tmp_path):
    rng = np.random.default_rng(4)
    n = 30000
    k = 40 + 10 * rng.standard_normal(n)
    per_sample = {"time_s": np.arange(n) / 1000.0, "stiffness": k, "stiffness_lo": k - rng.uniform(0, 5, n),
                  "stiffness_hi": np.where(rng.uniform(size=n) < 0.1, np.inf, k + rng.uniform(0, 5, n)),
                  "observable": rng.integers(0, 2, n)}
    per_sample["stiffness"][:50] = np.nan
    at = (np.arange(50) + 0.5) / 50
    by_phase = pd.DataFrame({"phase": at, "stiffness": np.where(at < 0.1, np.nan, 60 + np.sin(at)),
                             "stiffness_lo": 55 + at, "stiffness_hi": 65 + at, "n_cycles": np.arange(50)})
    result = SimpleNamespace(columns=lambda: dict(per_sample), to_dict=lambda: {"ok": True},
                             curve=SimpleNamespace(against="phase", to_frame=lambda: by_phase.copy()))
    write_result(result, tmp_path)
    assert (tmp_path / STIFFNESS_CSV).read_bytes() == _old_write(per_sample)
    assert (tmp_path / CURVE_CSV["phase"]).read_bytes() == _old_write(by_phase)


def test_columns_without_a_plain_number(tmp_path):
    n = 5
    columns = {"nan": np.full(n, np.nan), "inf": np.array([np.inf, -np.inf] * 2 + [np.inf]),
               "zero": np.array([0.0, -0.0, 0.0, -0.0, 0.0]), "big": np.array([10 ** 10, -10 ** 10, 2 ** 62, -2 ** 63, 7]),
               "tiny": np.full(n, -2.5e-320)}
    write_csv(tmp_path / "x.csv", columns)
    assert (tmp_path / "x.csv").read_bytes() == _reference(columns)
    write_csv(tmp_path / "one.csv", {k: v[:1] for k, v in columns.items()})
    assert (tmp_path / "one.csv").read_bytes() == _reference({k: v[:1] for k, v in columns.items()})
