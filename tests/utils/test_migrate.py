"""Schema steps: applied in order from a file's schema, on a copy; a newer or bad schema, or a
step that cannot read an old value, is one line naming the file."""

from __future__ import annotations

import json

import pytest

from lfd_track.errors import FileFormatError
from lfd_track.utils.migrate import VersionedJson, migrate, read_versioned


def _step(to: int):
    def step(data):
        data["seen"] = [*data.get("seen", []), to]
        data["schema"] = to
        return data

    return step


STEPS = (_step(2), _step(3))


def test_each_step_from_the_files_schema_runs_once_in_order():
    assert migrate({"schema": 1}, "f.json", what="thing", steps=STEPS) == {
        "schema": 3,
        "seen": [2, 3],
    }
    assert migrate({"schema": 2}, "f.json", what="thing", steps=STEPS)["seen"] == [3]
    current = {"schema": 3, "x": 1}
    assert migrate(current, "f.json", what="thing", steps=STEPS) is current


def test_a_dict_without_schema_is_schema_1_and_the_input_is_not_changed():
    data = {"nested": {"a": 1}}
    out = migrate(data, "f.json", what="thing", steps=STEPS)
    assert out["seen"] == [2, 3] and data == {"nested": {"a": 1}}
    out["nested"]["a"] = 2
    assert data["nested"]["a"] == 1


@pytest.mark.parametrize(
    ("schema", "problem"),
    [
        (4, "thing schema 4 is newer than this lfd-track reads (3); upgrade lfd-track"),
        (0, "thing schema must be an integer >= 1, got 0"),
        ("2", "thing schema must be an integer >= 1, got '2'"),
        (True, "thing schema must be an integer >= 1, got True"),
    ],
)
def test_a_newer_or_bad_schema_is_one_line_naming_the_file(schema, problem):
    with pytest.raises(FileFormatError) as exc:
        migrate({"schema": schema}, "dir/f.json", what="thing", steps=STEPS)
    assert str(exc.value).startswith("dir/f.json: ") and problem in str(exc.value)
    assert "\n" not in str(exc.value)


def test_a_value_no_step_can_read_is_one_line_naming_the_file():
    def refuses(data):
        raise ValueError("memory kind must be one of none, got 'x'\nmore")

    with pytest.raises(FileFormatError, match=r"^f.json: thing of schema 1 cannot be read: memory"):
        migrate({}, "f.json", what="thing", steps=(refuses,))


def test_reading_a_file_parses_and_migrates_it(tmp_path):
    path = tmp_path / "f.json"
    path.write_text(json.dumps({"schema": 2}))
    assert read_versioned(path, what="thing", steps=STEPS, max_bytes=100)["schema"] == 3
    for text, problem in [("[1]", "not a JSON object"), ("{", "unreadable thing"), ("NaN", "NaN")]:
        path.write_text(text)
        with pytest.raises(FileFormatError, match=problem) as exc:
            read_versioned(path, what="thing", steps=STEPS, max_bytes=100)
        assert str(exc.value).startswith(f"{path}: ")


def test_a_file_format_migrates_and_reads_through_its_own_steps_and_size(tmp_path):
    thing = VersionedJson("thing", STEPS, max_bytes=100)
    assert thing.current == 3
    assert thing.migrate({"schema": 1}, "f.json")["seen"] == [2, 3]
    path = tmp_path / "f.json"
    path.write_text(json.dumps({"schema": 2, "pad": "x" * 200}))
    with pytest.raises(FileFormatError, match=r"^.*f\.json: "):
        thing.read(path)  # over its own 100 bytes
    assert thing.read(path, max_bytes=1000)["seen"] == [3]
