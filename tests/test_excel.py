"""Excel workbooks (.xlsx, issue 35): read like CSV — the same column matching, units and checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import openpyxl
import pytest

from limbstiff.errors import ProtocolError, TrialError
from limbstiff.files import EXTENSIONS, read_trial, write_trial
from limbstiff.files.read import FOLDER_EXTENSIONS
from limbstiff.protocol import protocol_from_dict

from .conftest import multisine_trial

LAB = {"time": {"header": "Zeit", "unit": "ms"}, "angle": {"header": "Winkel", "unit": "deg"},
       "torque": {"header": "Moment", "unit": "Nm", "scale": -1.0}}


def workbook(path: Path, trial, *, sheet="Trial", before=(), header=("Zeit (ms)", "Winkel (°)", "Moment (Nm)"),
             units=None, other_sheet=None) -> Path:
    """``trial`` in ms, degrees and N·m on the worksheet ``sheet`` (after ``other_sheet``, if given)."""
    book = openpyxl.Workbook()
    first = book.active
    if other_sheet is not None:
        first.title = other_sheet
        first.append(["not the trial"])
        ws = book.create_sheet(sheet)
    else:
        ws = first
        ws.title = sheet
    for row in before:
        ws.append(list(row))
    ws.append(list(header))
    if units is not None:
        ws.append(list(units))
    for t, y, f in zip(trial.time, trial.angle, trial.torque):
        ws.append([float(t * 1e3), float(np.degrees(y)), float(f)])
    book.save(path)
    return path


def expect_error(path, phrase, protocol=None) -> str:
    with pytest.raises(TrialError) as info:
        read_trial(path, protocol)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and phrase in message and "\n" not in message, message
    return message


def test_a_workbook_reads_like_the_same_numbers_in_csv(tmp_path):
    trial = multisine_trial(duration=4.0)
    path = workbook(tmp_path / "lab.xlsx", trial, before=[["# subject: S01"], ["# side", "left"], []])
    read = read_trial(path, protocol_from_dict({"columns": LAB}))
    np.testing.assert_allclose(read.time, trial.time, atol=1e-9)
    np.testing.assert_allclose(read.angle, trial.angle, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(read.torque, -trial.torque, rtol=1e-12, atol=1e-15)
    assert dict(read.metadata) == {"subject": "S01", "side": "left"} and read.warnings == ()
    assert read.name == "lab" and read.kind == "rotational"
    # the same numbers through the CSV reader give the same trial
    write_trial(read, tmp_path / "lab.csv")
    np.testing.assert_allclose(read_trial(tmp_path / "lab.csv").angle, read.angle, rtol=1e-12, atol=1e-15)
    # standard headers need no protocol; a unit row makes plain quantity headers standard
    plain = workbook(tmp_path / "plain.xlsx", trial, header=("time", "angle", "torque", "note"),
                     units=("ms", "[deg]", "Nm"))
    read = read_trial(plain)
    np.testing.assert_allclose(read.angle, trial.angle, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(read.torque, trial.torque, rtol=1e-12, atol=1e-15)


def test_a_text_cell_in_the_data_is_one_error_naming_row_and_column(tmp_path):
    trial = multisine_trial(duration=4.0)
    path = workbook(tmp_path / "lab.xlsx", trial)
    book = openpyxl.load_workbook(path)
    book["Trial"]["B12"] = "n/a"            # row 12: the 11th sample under the header
    book.save(path)
    message = expect_error(path, "non-numeric value 'n/a' in column 'Winkel (°)' (B) at row 12 (t = ",
                           protocol_from_dict({"columns": LAB}))
    assert f"(t = {trial.time[10]:g} s)" in message
    book["Trial"]["B12"] = "1.5"            # a number stored as text: said so
    book["Trial"]["C20"] = None
    book.save(path)
    expect_error(path, "non-numeric value '1.5' in column 'Winkel (°)' (B) at row 12", protocol_from_dict({"columns": LAB}))
    book["Trial"]["B12"] = 1.5
    book.save(path)
    expect_error(path, "empty cell in column 'Moment (Nm)' (C) at row 20", protocol_from_dict({"columns": LAB}))


def test_the_protocols_sheet_key_names_the_worksheet(tmp_path):
    trial = multisine_trial(duration=4.0)
    path = workbook(tmp_path / "lab.xlsx", trial, sheet="Trial 2", other_sheet="Notes")
    expect_error(path, "column 'Zeit' given by the protocol for time is not in the file (headers found: not the trial)",
                 protocol_from_dict({"columns": LAB}))          # the first sheet, without [format] sheet
    read = read_trial(path, protocol_from_dict({"columns": LAB, "format": {"sheet": "Trial 2"}}))
    np.testing.assert_allclose(read.angle, trial.angle, rtol=1e-12, atol=1e-15)
    # a protocol without the key keeps its settings (and their hash)
    assert "sheet" not in protocol_from_dict({"columns": LAB}).to_dict()
    assert protocol_from_dict({"format": {"sheet": "Trial 2"}}).to_dict()["sheet"] == "Trial 2"
    with pytest.raises(ProtocolError, match="'sheet' in \\[format\\] must be a worksheet's name"):
        protocol_from_dict({"format": {"sheet": ""}})


def test_a_missing_sheet_is_one_error_listing_the_sheets(tmp_path):
    path = workbook(tmp_path / "lab.xlsx", multisine_trial(duration=4.0), sheet="Trial 2", other_sheet="Notes")
    expect_error(path, "no sheet 'Trial 1' in the workbook (sheets: 'Notes', 'Trial 2'); check [format] sheet",
                 protocol_from_dict({"columns": LAB, "format": {"sheet": "Trial 1"}}))


def test_xls_and_damaged_workbooks_are_one_line_errors(tmp_path):
    old = tmp_path / "old.xls"
    old.write_bytes(b"\xd0\xcf\x11\xe0\xa1\xb1\x1a\xe1" + bytes(512))
    expect_error(old, "old binary Excel workbook (.xls) is not read: save it as .xlsx or .csv")
    damaged = tmp_path / "damaged.xlsx"
    damaged.write_bytes(b"PK\x03\x04" + bytes(range(256)))
    expect_error(damaged, "cannot be read as an .xlsx workbook (BadZipFile): open it in Excel and save it")
    renamed = tmp_path / "renamed.xlsx"                 # a CSV named .xlsx
    renamed.write_text("time_s,angle_rad,torque_Nm\n0,0,0\n")
    expect_error(renamed, "not an .xlsx workbook (it is not a ZIP archive)")
    png = tmp_path / "png.xlsx"
    png.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    expect_error(png, "not an .xlsx workbook (it looks like a PNG image): save it from Excel as .xlsx")
    old_named_new = tmp_path / "old.xlsx"
    old_named_new.write_bytes(old.read_bytes())
    expect_error(old_named_new, "not an .xlsx workbook (it looks like an old Office file, such as an .xls workbook)")


def test_folders_are_searched_for_workbooks():
    assert ".xlsx" in EXTENSIONS and ".xlsx" in FOLDER_EXTENSIONS and ".xls" not in EXTENSIONS


def test_a_damaged_worksheet_is_one_line_error(tmp_path):
    # read-only workbooks parse each sheet lazily, after load_workbook succeeded: a truncated
    # sheet's XML fails there (it escaped as an xml ParseError before)
    import zipfile
    good = workbook(tmp_path / "good.xlsx", multisine_trial(duration=1.0))
    bad = tmp_path / "bad.xlsx"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(bad, "w") as dst:
        for item in src.infolist():
            data = src.read(item.filename)
            dst.writestr(item, data[: len(data) // 2] if item.filename.startswith("xl/worksheets/") else data)
    expect_error(bad, "cannot be read as an .xlsx workbook", protocol_from_dict({"columns": LAB}))
