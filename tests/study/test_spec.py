"""Study files: what a valid one means, and one-line errors for bad ones."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from study_helpers import TINY_STUDY, write_study

from lfd_track.cli import main
from lfd_track.errors import FileFormatError
from lfd_track.study.spec import available_methods, load_study

REPO = Path(__file__).resolve().parents[2]


def test_conditions_take_defaults_and_seeds_are_matched(tmp_path):
    path = write_study(
        tmp_path,
        TINY_STUDY
        + """
[[conditions]]
name = "careless+long"
description = "the paper's warning, with a longer evolution"
[conditions.human]
careful = false
[conditions.ga]
population_size = 20
""",
    )
    study = load_study(path)
    assert study.name == "tiny" and study.seeds == (0, 1) and study.repetitions == 1
    paper, careless = study.conditions
    assert paper.method == "paper" and paper.config.preset == "paper"
    # [defaults.ga] and the condition's own [conditions.ga] are merged key by key.
    assert careless.config.ga.generations == 5 and careless.config.ga.population_size == 20
    assert careless.config.human.careful is False and paper.config.human.careful is True
    assert careless.config.trials_per_direction == 1
    jobs = study.jobs()
    assert [j.key for j in jobs] == [
        "paper/seed0",
        "careless+long/seed0",
        "paper/seed1",
        "careless+long/seed1",
    ]
    # Matched seeds: the same benchmark seed (so the same demonstration seeds) in each condition.
    assert [j.config.seed for j in jobs] == [0, 0, 1, 1]
    assert all(j.config.repetitions == 1 for j in jobs)


def test_preset_paths_are_relative_to_the_study_file(tmp_path):
    (tmp_path / "presets").mkdir()
    preset = (REPO / "envs" / "paper.toml").read_text()
    (tmp_path / "presets" / "mine.toml").write_text(
        preset.replace('name = "paper"', 'name = "mine"')
    )
    path = write_study(
        tmp_path, TINY_STUDY.replace('preset = "paper"', 'preset = "presets/mine.toml"')
    )
    (condition,) = load_study(path).conditions
    assert condition.config.preset == str(tmp_path / "presets" / "mine.toml")


BAD = [
    ("this is = not toml [", "not valid TOML"),
    (TINY_STUDY.replace("[study]", "[studdy]"), "unknown table or key 'studdy'"),
    (TINY_STUDY.replace("seeds = [0, 1]", "seeds = []"), "'study.seeds' must be a non-empty"),
    (TINY_STUDY.replace("seeds = [0, 1]", "seeds = [0, 0]"), "lists a seed twice"),
    (TINY_STUDY.replace("seeds = [0, 1]", "seeds = [-1]"), "integers >= 0"),
    (TINY_STUDY.replace("repetitions = 1", "repetitions = 0"), "'study.repetitions' must be"),
    (TINY_STUDY.replace('preset = "paper"', 'preset = "nosuch"'), "unknown preset 'nosuch'"),
    (TINY_STUDY.replace('method = "paper"', 'method = "magic"'), "unknown method 'magic'"),
    (TINY_STUDY.replace("generations = 5", "generations = 0"), "generations must be at least 1"),
    (TINY_STUDY.replace("generations = 5", "generatons = 5"), "unknown key 'paper.ga.generatons'"),
    (TINY_STUDY.replace("generations = 5", 'generations = "many"'), "must be an integer"),
    (TINY_STUDY + "\nseed = 3\n", "'seed' is set by the [study] table"),
    (TINY_STUDY + "\ncolour = 3\n", "condition 'paper': unknown key 'colour'"),
    (TINY_STUDY + '\n[[conditions]]\nname = "paper"\n', "two conditions are named 'paper'"),
    (TINY_STUDY + '\n[[conditions]]\nname = "a b"\n', "needs a 'name'"),
    (TINY_STUDY.split("[[conditions]]")[0], "no [[conditions]]"),
    (
        TINY_STUDY.replace("trials_per_direction = 1", "trials_per_direction = 0"),
        "[paper] trials",
    ),
    (
        TINY_STUDY + "[conditions.online.intervention]\nbogus = 1\n",
        "unknown key 'paper.online.intervention.bogus'",
    ),
    (
        TINY_STUDY + '[conditions.hg_dagger.intervention]\nstall_commands = "x"\n',
        "'paper.hg_dagger.intervention.stall_commands' must be an integer",
    ),
    (TINY_STUDY + "[conditions.human]\nmax_commands = 0\n", "'human.max_commands' must be at"),
]


@pytest.mark.parametrize(("text", "problem"), BAD, ids=[p for _, p in BAD])
def test_bad_study_files_fail_with_one_line_naming_the_file(tmp_path, capsys, text, problem):
    path = write_study(tmp_path, text, name="bad.toml")
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert err.startswith(f"lfd-track study: {path}: "), err
    assert problem in err
    assert not out.exists()  # nothing is created for a bad study


def test_missing_study_file_and_bad_flags(tmp_path, capsys):
    assert main(["--quiet", "study", str(tmp_path / "none.toml"), "--out", str(tmp_path)]) == 1
    assert "none.toml: TOML file not found" in capsys.readouterr().err
    path = write_study(tmp_path)
    assert main(["study", str(path), "--out", str(tmp_path / "o"), "--address", "auto"]) == 1
    assert "--address needs --executor ray" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(["study", str(path), "--out", str(tmp_path / "o"), "--workers", "0"])
    assert exc.value.code == 2
    with pytest.raises(SystemExit):
        main(["study", str(path), "--out", str(tmp_path / "o"), "--executor", "dask"])
    assert not (tmp_path / "o").exists()


def test_the_committed_study_names_the_conditions_of_the_plan():
    path = REPO / "benchmarks" / "experiments" / "beyond_the_paper" / "beyond_the_paper.toml"
    study = load_study(path, check_names=False)
    assert study.seeds == (0, 1, 2) and study.repetitions == 10
    rows = {c.name: (c.method, c.config.preset) for c in study.conditions}
    assert rows == {
        "paper": ("paper", "paper"),
        "paper+wide": ("paper", "wide"),
        "online": ("online", "paper"),
        "online+wide": ("online", "wide"),
        "hg-dagger": ("hg-dagger", "paper"),
        "bc": ("bc", "paper"),
        "cma-es": ("cma-es", "paper"),
    }
    assert all(c.config.trials_per_direction == 3 for c in study.conditions)
    # Scored on the paper's testing track and on every unseen loop (a study that lists only the
    # unseen loops would not lap the testing track at all).
    from lfd_track.world.track import UNSEEN_TRACKS

    assert all(set(c.test_tracks) == {"testing", *UNSEEN_TRACKS} for c in study.conditions)


def test_the_committed_study_validates_once_its_methods_presets_and_tracks_exist():
    path = REPO / "benchmarks" / "experiments" / "beyond_the_paper" / "beyond_the_paper.toml"
    study = load_study(path, check_names=False)
    needed_methods = {c.method for c in study.conditions}
    missing = sorted(needed_methods - set(available_methods() or needed_methods))
    missing += sorted(
        {c.config.preset for c in study.conditions}
        - {p.stem for p in (REPO / "envs").glob("*.toml")}
    )
    missing += sorted(
        {t for c in study.conditions for t in c.test_tracks}
        - {p.stem for p in (REPO / "tracks").glob("*.toml")}
    )
    if not missing:
        load_study(path)  # every name exists: the full check must pass
    else:
        # Until they land, the full check fails naming one of the missing names.
        with pytest.raises(FileFormatError, match="|".join(f"'{re.escape(m)}'" for m in missing)):
            load_study(path)


def test_the_documented_example_study_is_valid(tmp_path):
    section = (REPO / "docs" / "studies.md").read_text(encoding="utf-8")
    example = section[section.index("```toml") + len("```toml") : section.index("```\n", 10)]
    study = load_study(write_study(tmp_path, example))
    assert [c.name for c in study.conditions] == ["paper", "short-ga"]
    assert study.conditions[1].config.ga.generations == 50 and study.seeds == (0, 1, 2)


BIG = "1" + "0" * 400  # 10**400: parses as TOML, overflows anything of C size
HUGE = [
    (
        TINY_STUDY.replace("repetitions = 1", "repetitions = 1000000000000"),
        "'study.repetitions' must be at most 10000",
    ),
    (TINY_STUDY.replace("repetitions = 1", f"repetitions = {BIG}"), "'study.repetitions'"),
    (TINY_STUDY.replace("seeds = [0, 1]", f"seeds = [0, {BIG}]"), "'study.seeds' must be"),
    (TINY_STUDY.replace("seeds = [0, 1]", "seeds = [4294967296]"), "from 0 to 4294967295"),
    (
        TINY_STUDY.replace("trials_per_direction = 1", f"trials_per_direction = {BIG}"),
        "trials_per_direction'? must be at most 1000",
    ),
    (
        TINY_STUDY + "[conditions.ga]\npopulation_size = 1000000000000\n",
        "population_size'? must be at most 100000",
    ),
]


@pytest.mark.parametrize(("text", "problem"), HUGE, ids=[f"huge-{i}" for i in range(len(HUGE))])
def test_huge_numbers_fail_at_load_in_one_line(tmp_path, capsys, text, problem):
    path = write_study(tmp_path, text, name="huge.toml")
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"lfd-track study: {path}: "), err
    assert re.search(problem, err) and len(err) < 300, err  # 401 digits are not printed whole
    assert not out.exists()


def _integer_settings(cls=None, prefix=""):
    """Dotted paths of every integer setting a condition can set (nested tables included)."""
    import dataclasses
    import typing

    from lfd_track.benchmark.runner import BenchmarkConfig

    cls = cls or BenchmarkConfig
    hints = typing.get_type_hints(cls)
    for f in dataclasses.fields(cls):
        kind = hints[f.name]
        if dataclasses.is_dataclass(kind):
            yield from _integer_settings(kind, f"{prefix}{f.name}.")
        elif kind is int and f"{prefix}{f.name}" not in ("seed", "repetitions"):
            yield f"{prefix}{f.name}"


@pytest.mark.parametrize("key", list(_integer_settings()))
def test_every_integer_setting_of_a_condition_has_an_upper_bound(tmp_path, key):
    *tables, leaf = key.split(".")
    setting = f"{leaf} = {BIG}\n"
    text = TINY_STUDY + (f"[conditions.{'.'.join(tables)}]\n" if tables else "") + setting
    path = write_study(tmp_path, text, name="huge.toml")
    with pytest.raises(FileFormatError) as exc:
        load_study(path, check_names=False)
    message = str(exc.value)
    assert message.startswith(f"{path}: ") and "\n" not in message and len(message) < 300
    assert leaf in message, message


def test_limits_are_generous_enough_for_real_studies(tmp_path):
    text = (
        TINY_STUDY.replace("seeds = [0, 1]", "seeds = [0, 4294967295]")
        .replace("repetitions = 1", "repetitions = 10000")
        .replace("trials_per_direction = 1", "trials_per_direction = 1000")
        + "[conditions.ga]\npopulation_size = 100000\n"
    )
    study = load_study(write_study(tmp_path, text))
    assert study.seeds == (0, 2**32 - 1) and study.repetitions == 10_000
    assert study.conditions[0].config.ga.population_size == 100_000


LOOP_WITHOUT_CORNERS = """
name = "plain"
closed = true
width_m = 0.30
vertices = [[0.0, 0.0], [3.0, 0.0], [3.0, 1.8], [1.8, 1.8]]
"""


@pytest.mark.parametrize(
    ("tracks", "problem"),
    [
        ('["training"]', "test track 'training' is not a loop"),
        ('["testing", "open.toml"]', "open.toml' is not a loop"),
        ('["plain.toml"]', "plain.toml' has no corners"),
    ],
)
def test_test_tracks_must_be_loops_with_corners(tmp_path, capsys, tracks, problem):
    (tmp_path / "open.toml").write_text((REPO / "tracks" / "training.toml").read_text())
    (tmp_path / "plain.toml").write_text(LOOP_WITHOUT_CORNERS)
    path = write_study(tmp_path, TINY_STUDY + f"test_tracks = {tracks}\n", name="tracks.toml")
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"lfd-track study: {path}: "), err
    assert "condition 'paper'" in err and problem in err, err
    assert not out.exists()  # refused before any demonstration or learning ran
    load_study(path, check_names=False)  # the structure alone is fine


def test_demo_track_is_relative_to_the_study_file_and_must_exist(tmp_path, capsys):
    (tmp_path / "tracks").mkdir()
    (tmp_path / "tracks" / "open.toml").write_text((REPO / "tracks" / "training.toml").read_text())
    path = write_study(tmp_path, TINY_STUDY + 'demo_track = "tracks/open.toml"\n')
    (condition,) = load_study(path).conditions
    assert condition.config.demo_track == str(tmp_path / "tracks" / "open.toml")
    missing = write_study(
        tmp_path, TINY_STUDY + 'demo_track = "tracks/missing.toml"\n', name="missing.toml"
    )
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(missing), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"lfd-track study: {missing}: "), err
    assert "missing.toml" in err, err
    assert not out.exists()
