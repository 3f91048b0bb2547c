"""study.json schemas: a study writes the current one; every committed study.json reads as it,
each condition's settings whole; a newer one fails in one line naming the file."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from study_helpers import TINY_STUDY, write_study

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.benchmark.tables import results_json_text
from lfd_track.errors import FileFormatError
from lfd_track.study.schema import STUDY_FORMAT, STUDY_SCHEMA, migrate_study, read_study_results
from lfd_track.study.spec import load_study
from lfd_track.study.summary import build_study_results

REPO = Path(__file__).resolve().parents[2]
COMMITTED = sorted(str(p.relative_to(REPO)) for p in (REPO / "benchmarks").rglob("study.json"))


def _stored(value):
    return json.loads(results_json_text({"x": value}))["x"]


@pytest.mark.parametrize("path", COMMITTED)
def test_a_committed_study_json_reads_as_the_current_schema(path):
    summary = read_study_results(REPO / path)
    assert summary["schema"] == STUDY_SCHEMA == STUDY_FORMAT.current == 13
    for condition in summary["conditions"]:
        # A condition stores its settings without the job's seed and repetitions.
        config = {**condition["config"], "seed": 0, "repetitions": condition["repetitions"]}
        again = _stored(config_dict(BenchmarkConfig.from_dict(config)))
        assert {k: v for k, v in again.items() if k not in ("seed", "repetitions")} == (
            condition["config"]
        )


def test_a_study_writes_the_current_schema_with_every_setting(tmp_path):
    study = load_study(write_study(tmp_path, TINY_STUDY))
    summary = _stored(build_study_results(study, []))
    assert summary["schema"] == STUDY_SCHEMA
    assert migrate_study(summary, "study.json") is summary
    (condition,) = summary["conditions"]
    full = _stored(config_dict(study.conditions[0].config))
    assert condition["config"] == {
        k: v for k, v in full.items() if k not in ("seed", "repetitions")
    }


def test_a_newer_study_json_fails_in_one_line_naming_the_file(tmp_path):
    path = tmp_path / "study.json"
    path.write_text(json.dumps({"schema": STUDY_SCHEMA + 1, "conditions": []}))
    with pytest.raises(FileFormatError) as exc:
        read_study_results(path)
    assert str(exc.value).startswith(f"{path}: study schema {STUDY_SCHEMA + 1} is newer")
    assert "\n" not in str(exc.value)


def _smallest_studies(count: int) -> list[str]:
    """The committed study folders with the fewest jobs (pooling them again is quick)."""
    folders = [(REPO / p).parent for p in COMMITTED]
    folders.sort(key=lambda f: (sum(1 for _ in f.rglob("results.json")), str(f)))
    return [str(f.relative_to(REPO)) for f in folders[:count]]


@pytest.mark.parametrize("folder", _smallest_studies(3))
def test_a_committed_study_md_is_what_its_migrated_jobs_pool_to(folder, monkeypatch):
    """The summary is unchanged by reading the jobs as the current schema (every committed study.md is
    reproduced so; three are checked here to keep the suite quick)."""
    from lfd_track.study.run import load_finished
    from lfd_track.study.summary import study_markdown

    committed = read_study_results(REPO / folder / "study.json")
    source = (REPO / folder).parents[1] / f"{committed['study']}.toml"  # results/<stem> beside it
    monkeypatch.chdir(REPO)  # as the studies were run (paths in them are relative to the root)
    study = load_study(source.relative_to(REPO))
    pooled = build_study_results(study, load_finished(study, REPO / folder))
    assert study_markdown(pooled) == (REPO / folder / "study.md").read_text(encoding="utf-8")


def test_a_stored_job_of_a_newer_schema_stops_the_study_in_one_line_naming_it(tmp_path):
    from study_helpers import job_results

    from lfd_track.study.jobs import RESULTS_FILE, finished_results

    study = load_study(write_study(tmp_path, TINY_STUDY))
    job = study.jobs()[0]
    path = tmp_path / "out" / job.key / RESULTS_FILE
    path.parent.mkdir(parents=True)
    path.write_text(json.dumps({**job_results(job), "schema": 14}))
    with pytest.raises(FileFormatError) as exc:
        finished_results(tmp_path / "out", job)
    assert str(exc.value) == (
        f"{path}: results schema 14 is newer than this lfd-track reads (13); upgrade lfd-track to"
        " read it"
    )
    path.write_text(json.dumps({**job_results(job), "schema": 1}))  # schema 1 reads as before
    assert finished_results(tmp_path / "out", job)["schema"] == 13
