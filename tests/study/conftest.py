"""A tiny study (1 condition x 2 seeds x 1 repetition, 5 GA generations, 1 trial per direction)
run once with the local executor and shared by the study tests."""

from __future__ import annotations

import pytest
from study_helpers import write_study


@pytest.fixture(scope="session")
def tiny_study(tmp_path_factory):
    """(study file, output folder, StudyRun) after one local, in-process run."""
    from lfd_track.study.run import load_finished, run_study
    from lfd_track.study.spec import load_study
    from lfd_track.study.summary import write_study_outputs

    folder = tmp_path_factory.mktemp("study")
    path = write_study(folder)
    study = load_study(path)
    out = folder / "out"
    run = run_study(study, out, executor="local", workers=1)
    write_study_outputs(out, study, load_finished(study, out))
    return path, out, run
