"""Minari datasets of LfDTrack-v0: export, read back with the real minari, recover the env, and
learn from them exactly as from the recordings (lfd_track/dataset/minari/)."""

from __future__ import annotations

import dataclasses
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import minari  # noqa: E402  (the minari extra is part of the test extra)
import numpy as np
import pytest

from lfd_track.cli import main
from lfd_track.dataset import load_demonstration, save_demonstration
from lfd_track.dataset.minari import METADATA_KEY, cases_from_minari, export_minari
from lfd_track.dataset.sample import write_sample_data
from lfd_track.errors import LfdTrackError
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.learning.learners import BCLearner, GALearner
from lfd_track.policy.controller import Controller

DATASET = "lfd-track/sample-v0"


@pytest.fixture(scope="module")
def sample(tmp_path_factory) -> list[Path]:
    """The shipped sample demonstrations, unpacked."""
    folder = tmp_path_factory.mktemp("sample")
    return [path for path, _ in write_sample_data(folder)]


@pytest.fixture(scope="module")
def exported(sample, tmp_path_factory) -> Path:
    """The first two sample demonstrations as one dataset; returns the datasets folder."""
    root = tmp_path_factory.mktemp("minari-datasets")
    export_minari(sample[:2], DATASET, datasets_path=root)
    return root


@pytest.fixture
def minari_root(exported, monkeypatch):
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(exported))
    return exported


def test_minari_loads_the_episodes_as_recorded(sample, minari_root):
    dataset = minari.load_dataset(DATASET)
    assert dataset.total_episodes == 2
    demos = [load_demonstration(p) for p in sample[:2]]
    assert dataset.total_steps == sum(d.n_cases for d in demos)
    assert str(dataset.action_space) == "Discrete(3)"
    assert dataset.observation_space.shape == (40,)
    carried = json.loads(dataset.storage.metadata[METADATA_KEY])
    for episode, demo in zip(dataset.iterate_episodes(), demos, strict=True):
        n = demo.n_cases
        assert len(episode) == n
        assert np.array_equal(episode.actions, demo.commands)
        assert episode.observations.dtype == np.float64
        assert np.array_equal(episode.observations[:n], demo.road_values)
        # The frame after the last command is not recorded: the last observation repeats.
        assert np.array_equal(episode.observations[n], demo.road_values[-1])
        assert not episode.terminations.any() and episode.truncations.tolist() == [False] * (
            n - 1
        ) + [True]
        infos = episode.infos
        assert infos["case"].tolist() == [*range(n), -1]
        assert np.array_equal(infos["step"][:n], demo.steps)
        assert np.array_equal(infos["histograms"][:n], demo.histograms)
        assert np.array_equal(infos["pose"][:n], demo.poses)
        assert np.array_equal(infos["learned"][:n], demo.learned)
        assert infos["memory"].shape == (n + 1, 0)
        phases = carried["phases"]
        assert [phases[i] for i in infos["phase"][:n]] == demo.phases.tolist()
        assert infos["phase"][n] == -1
    assert [f["name"] for f in carried["files"]] == [p.name for p in sample[:2]]
    assert (
        carried["files"][1]["road_library"]
        == load_demonstration(sample[1]).metadata["road_library"]
    )


def test_the_recovered_env_observes_road_values(sample, minari_root):
    dataset = minari.load_dataset(DATASET)
    env = dataset.recover_environment()
    try:
        assert env.spec.id == "LfDTrack-v0"
        assert env.spec.kwargs["track"] == "training"
        assert env.observation_space == dataset.observation_space
        obs, _ = env.reset(seed=0)
        for action in (0, 1, 2):
            assert env.observation_space.contains(obs)
            obs, reward, terminated, truncated, info = env.step(action)
        assert obs.shape == (40,) and obs.dtype == np.float64 and np.abs(obs).max() > 0
        assert info["step"] == 3
        # It is the first file's library the wrapper sees with.
        library = load_demonstration(sample[0]).road_library()
        assert env.get_wrapper_attr("library").to_dict() == library.to_dict()
    finally:
        env.close()


def test_learning_from_the_dataset_equals_learning_from_the_file(sample, tmp_path):
    root = tmp_path / "datasets"
    export_minari(sample[:1], "one-v0", datasets_path=root)
    cases = cases_from_minari("one-v0", datasets_path=root)
    demo = load_demonstration(sample[0])
    assert np.array_equal(cases.inputs, demo.inputs)
    assert np.array_equal(cases.actions, demo.commands)
    assert cases.recomputed_cases == 0 and cases.memory is None
    assert cases.library.to_dict() == demo.road_library().to_dict()
    config = GAConfig(generations=3, population_size=8)
    from_file = GALearner(config).fit(demo.inputs, demo.commands, np.random.default_rng(5))
    from_minari = GALearner(config).fit(cases.inputs, cases.actions, np.random.default_rng(5))
    assert np.array_equal(from_file.weights, from_minari.weights)
    bc = BCConfig(epochs=3)
    assert np.array_equal(
        BCLearner(bc).fit(demo.inputs, demo.commands, np.random.default_rng(1)).weights,
        BCLearner(bc).fit(cases.inputs, cases.actions, np.random.default_rng(1)).weights,
    )


def test_evolve_minari_gives_the_controller_evolve_gives(sample, tmp_path, capsys):
    root = tmp_path / "datasets"
    args = ["-q", "export", "minari", str(sample[0]), "--dataset-id", "lfd-track/one-v0"]
    assert main([*args, "--datasets-path", str(root)]) == 0
    assert "38 cases in 1 episode of 1 demonstration," in capsys.readouterr().out
    common = ["--generations", "3", "--seed", "2"]
    assert main(["-q", "evolve", str(sample[0]), *common, "--out", str(tmp_path / "a.json")]) == 0
    minari_args = ["--minari", "lfd-track/one-v0", "--datasets-path", str(root)]
    assert main(["-q", "evolve", *minari_args, *common, "--out", str(tmp_path / "b.json")]) == 0
    a = Controller.load(tmp_path / "a.json")
    b = Controller.load(tmp_path / "b.json")
    demo = load_demonstration(sample[0])
    assert [a.act_on_values(v) for v in demo.road_values] == [
        b.act_on_values(v) for v in demo.road_values
    ]
    assert a.to_dict()["weights"] == b.to_dict()["weights"]
    assert a.library.to_dict() == b.library.to_dict()


def test_episodes_of_another_library_are_recomputed_from_their_histograms(exported, sample):
    cases = cases_from_minari(DATASET, datasets_path=exported)
    first, second = (load_demonstration(p) for p in sample[:2])
    assert cases.n_episodes == 2 and cases.recomputed_cases == second.n_cases
    assert np.array_equal(cases.inputs[: first.n_cases], first.road_values)
    library = first.road_library()
    expected = [
        library.road_values_from_histograms(h, update_statistics=False) for h in second.histograms
    ]
    assert np.array_equal(cases.inputs[first.n_cases :], np.array(expected))
    assert np.array_equal(cases.actions, np.r_[first.commands, second.commands])


def _subset(demo, keep, **metadata):
    """``demo`` with only the cases ``keep`` (and ``metadata`` changed)."""
    arrays = "commands road_values histograms poses progress_m phases learned steps sources rounds memory"
    changes = {name: getattr(demo, name)[keep] for name in arrays.split()}
    return dataclasses.replace(demo, metadata=dict(demo.metadata, **metadata), **changes)


def test_gaps_in_the_steps_start_new_episodes(sample, tmp_path):
    demo = load_demonstration(sample[0])
    keep = np.r_[0:10, 15 : demo.n_cases]
    gapped = tmp_path / "gapped.lfdemo"
    save_demonstration(gapped, _subset(demo, keep))
    root = tmp_path / "datasets"
    export_minari([gapped], "gap-v0", datasets_path=root)
    cases = cases_from_minari("gap-v0", datasets_path=root)
    assert cases.n_episodes == 2
    assert np.array_equal(cases.inputs, demo.road_values[keep])
    dataset = _load(root, "gap-v0")
    assert [len(e) for e in dataset.iterate_episodes()] == [10, demo.n_cases - 15]


def _load(root, dataset_id):
    os.environ["MINARI_DATASETS_PATH"] = str(root)
    try:
        return minari.load_dataset(dataset_id)
    finally:
        del os.environ["MINARI_DATASETS_PATH"]


# ----------------------------------------------------------------------------------- errors
def _run(args, capsys):
    code = main(args)
    err = capsys.readouterr().err
    return code, err


def test_an_existing_dataset_is_kept_without_force(sample, tmp_path, capsys):
    root = tmp_path / "datasets"
    base = ["export", "minari", "--dataset-id", "lfd-track/k-v0", "--datasets-path", str(root)]
    assert main([*base, str(sample[0])]) == 0
    before = (root / "lfd-track/k-v0/data/main_data.hdf5").read_bytes()
    code, err = _run([*base, str(sample[1])], capsys)
    assert code == 1 and len(err.strip().splitlines()) == 1
    assert "lfd-track/k-v0 already exists" in err and "--force" in err
    assert (root / "lfd-track/k-v0/data/main_data.hdf5").read_bytes() == before
    assert main([*base, str(sample[1]), "--force"]) == 0
    assert cases_from_minari("lfd-track/k-v0", datasets_path=root).n_cases == 35
    assert sorted(p.name for p in root.iterdir()) == ["lfd-track"]  # no staging left behind


def test_a_failed_replacement_keeps_the_dataset(sample, tmp_path, capsys):
    root = tmp_path / "datasets"
    base = ["export", "minari", "--dataset-id", "k-v0", "--datasets-path", str(root)]
    assert main([*base, str(sample[0])]) == 0
    bad = tmp_path / "bad.lfdemo"
    bad.write_bytes(b"\x89LFDEMO\n" + b"\x01" * 40)
    code, err = _run([*base, str(sample[1]), str(bad), "--force"], capsys)
    assert code == 1 and err.count("\n") == 1 and str(bad) in err
    assert cases_from_minari("k-v0", datasets_path=root).n_cases == 38


@pytest.mark.parametrize(
    ("content", "problem"),
    [
        (b"", "empty file"),
        (b"not a recording at all", "bad magic"),
        (None, "not found"),
    ],
)
def test_a_bad_input_file_is_one_line(tmp_path, capsys, content, problem):
    path = tmp_path / "in.lfdemo"
    if content is not None:
        path.write_bytes(content)
    code, err = _run(
        ["export", "minari", str(path), "--dataset-id", "x-v0", "--datasets-path", str(tmp_path)],
        capsys,
    )
    assert code == 1 and err.count("\n") == 1
    assert str(path) in err and problem in err
    assert not (tmp_path / "x-v0").exists()


def test_frames_of_a_scripted_demonstration_are_exported_from_its_replay(sample, tmp_path):
    from lfd_track.vision.road_library import RoadLibrary

    export_minari(sample[:1], "f-v0", observations="frames", datasets_path=tmp_path)
    os.environ["MINARI_DATASETS_PATH"] = str(tmp_path)
    try:
        dataset = minari.load_dataset("f-v0")
        (episode,) = list(dataset.iterate_episodes())
        env = dataset.recover_environment()
        obs, _ = env.reset(seed=0)
        env.close()
    finally:
        del os.environ["MINARI_DATASETS_PATH"]
    demo = load_demonstration(sample[0])
    n = demo.n_cases
    assert dataset.observation_space.shape == (480, 640, 3) and obs.shape == (480, 640, 3)
    frames = episode.observations
    assert frames.shape == (n + 1, 480, 640, 3) and frames.dtype == np.uint8
    assert np.array_equal(frames[n], frames[n - 1])  # the final observation repeats the last
    assert np.array_equal(episode.actions, demo.commands)
    # Each exported frame is the one the case was recorded from: its region histograms (which
    # depend on the frame alone, not on the library) are the recorded ones.
    histograms = RoadLibrary(bins=demo.bins)
    for i in (0, n // 2, n - 1):
        assert np.allclose(histograms.region_histograms(frames[i]), demo.histograms[i], atol=1e-6)
    assert np.array_equal(episode.infos["road_values"][:n], demo.road_values)
    # Learning from the frames dataset reads the recording's cases.
    cases = cases_from_minari("f-v0", datasets_path=tmp_path)
    assert np.array_equal(cases.inputs, demo.inputs)
    assert np.array_equal(cases.actions, demo.commands)


def test_frames_of_a_recording_that_does_not_replay_are_refused_in_one_line(
    sample, tmp_path, capsys
):
    demo = load_demonstration(sample[0])
    changed = tmp_path / "changed.lfdemo"
    meta = dict(demo.metadata)
    meta["seed"] = int(meta["seed"]) + 1  # another drive: the replay cannot match
    save_demonstration(changed, dataclasses.replace(demo, metadata=meta))
    args = ["export", "minari", str(changed), "--dataset-id", "f-v0"]
    code, err = _run([*args, "--observations", "frames", "--datasets-path", str(tmp_path)], capsys)
    assert code == 1 and err.count("\n") == 1
    assert str(changed) in err and "--observations road-values" in err
    assert not (tmp_path / "f-v0").exists()
    no_human = tmp_path / "taught.lfdemo"
    meta = {k: v for k, v in demo.metadata.items() if k != "human"}
    save_demonstration(no_human, dataclasses.replace(demo, metadata=meta))
    code, err = _run(
        [
            "export",
            "minari",
            str(no_human),
            "--dataset-id",
            "f-v0",
            "--observations",
            "frames",
            "--datasets-path",
            str(tmp_path),
        ],
        capsys,
    )
    assert code == 1 and err.count("\n") == 1 and "scripted demonstration" in err


def test_a_bad_dataset_id_and_a_missing_dataset_are_one_line(sample, tmp_path, capsys):
    args = ["export", "minari", str(sample[0]), "--datasets-path", str(tmp_path)]
    code, err = _run([*args, "--dataset-id", "no spaces-v0"], capsys)
    assert code == 1 and err.count("\n") == 1 and "NAME-vVERSION" in err
    code, err = _run([*args, "--dataset-id", "unversioned"], capsys)
    assert code == 1 and err.count("\n") == 1
    code, err = _run([*args, "--dataset-id", "../outside-v0"], capsys)
    assert code == 1 and err.count("\n") == 1 and "NAME-vVERSION" in err
    assert not (tmp_path.parent / "outside-v0").exists()
    out = str(tmp_path / "c.json")
    code, err = _run(
        ["evolve", "--minari", "gone-v0", "--datasets-path", str(tmp_path), "--out", out], capsys
    )
    assert code == 1 and err.count("\n") == 1 and "no Minari dataset gone-v0" in err
    code, err = _run(["evolve", "--out", out], capsys)
    assert code == 1 and "--minari" in err
    assert not Path(out).exists()


def test_recordings_of_different_tracks_are_one_line(sample, tmp_path):
    demo = load_demonstration(sample[0])
    other = tmp_path / "other.lfdemo"
    save_demonstration(other, _subset(demo, np.arange(demo.n_cases), track="sbend"))
    with pytest.raises(
        LfdTrackError,
        match=r"track 'sbend', but .*training-0.lfdemo has 'training'",
    ):
        export_minari([sample[0], other], "two-v0", datasets_path=tmp_path)


def test_a_dataset_not_written_by_lfd_track_is_one_line(tmp_path, monkeypatch):
    import gymnasium as gym
    from minari.data_collector import EpisodeBuffer

    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    buffer = EpisodeBuffer(
        observations=np.zeros((3, 40)),
        actions=np.zeros(2, dtype=np.int64),
        rewards=np.zeros(2),
        terminations=np.zeros(2, dtype=bool),
        truncations=np.array([False, True]),
    )
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        minari.create_dataset_from_buffers(
            "foreign-v0",
            [buffer],
            observation_space=gym.spaces.Box(-1, 1, (40,)),
            action_space=gym.spaces.Discrete(3),
        )
    with pytest.raises(LfdTrackError, match="not written by lfd-track"):
        cases_from_minari("foreign-v0", datasets_path=tmp_path)


def test_minari_brings_no_jax_or_torch():
    code = (
        "import sys, minari, lfd_track.dataset.minari;"
        "print([m for m in sys.modules if m.split('.')[0] in ('jax', 'torch', 'tensorflow')])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


CHILD = r"""
import sys
for name in sys.argv[1].split(","):
    sys.modules[name] = None
sys.path.insert(0, sys.argv[2])
from lfd_track.cli import main
sys.exit(main(sys.argv[3:]))
"""


@pytest.mark.parametrize(
    ("blocked", "command"), [("minari", "export"), ("h5py", "export"), ("PIL", "evolve")]
)
def test_without_the_minari_extra_the_commands_name_it_in_one_line(tmp_path, blocked, command):
    repo = Path(__file__).resolve().parents[2]
    args = {
        "export": ["export", "minari", "d.lfdemo", "--dataset-id", "a-v0"],
        "evolve": ["evolve", "--minari", "a-v0", "--out", "c.json"],
    }[command]
    proc = subprocess.run(
        [sys.executable, "-c", CHILD, blocked, str(repo), *args, "--datasets-path", "ds"],
        capture_output=True, text=True, cwd=tmp_path, timeout=300,
    )  # fmt: skip
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        f"lfd-track {command}: Minari datasets (export minari, evolve --minari) needs the"
        " minari extra: pip install 'lfd-track[minari]'"
    ]
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_memory_inputs_travel_with_the_cases(sample, tmp_path):
    from lfd_track.policy.memory import LastBendConfig

    demo = load_demonstration(sample[0])
    settings = LastBendConfig()
    memory = np.random.default_rng(0).choice([0.0, 0.5, 1.0], size=(demo.n_cases, 1))
    with_memory = dataclasses.replace(
        demo, memory=memory, metadata=dict(demo.metadata, memory=settings.to_dict())
    )
    path = tmp_path / "memory.lfdemo"
    save_demonstration(path, with_memory)
    root = tmp_path / "datasets"
    export_minari([path], "memory-v0", datasets_path=root)
    cases = cases_from_minari("memory-v0", datasets_path=root)
    assert np.array_equal(cases.inputs, load_demonstration(path).inputs)
    assert cases.inputs.shape == (demo.n_cases, 41) and cases.memory == settings
    with pytest.raises(LfdTrackError, match="memory settings"):
        export_minari([path, sample[1]], "mixed-v0", datasets_path=root)


@pytest.mark.parametrize(
    ("changes", "problem"),
    [
        ({"kind": "hardware"}, "a hardware recording, not a drive in LfDTrack-v0"),
        ({"track": None}, "records no track"),
        ({"road_library": None}, "no road library stored"),
    ],
)
def test_recordings_without_an_env_or_a_library_are_one_line(sample, tmp_path, changes, problem):
    demo = load_demonstration(sample[0])
    metadata = {k: v for k, v in dict(demo.metadata, **changes).items() if v is not None}
    path = tmp_path / "odd.lfdemo"
    save_demonstration(path, dataclasses.replace(demo, metadata=metadata))
    with pytest.raises(LfdTrackError, match=problem) as caught:
        export_minari([path], "odd-v0", datasets_path=tmp_path / "ds")
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)
    assert not (tmp_path / "ds" / "odd-v0").exists()


@pytest.fixture(scope="module")
def one_file_dataset(sample, tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("one-file")
    export_minari(sample[:1], "t-v0", datasets_path=root)
    return root


def _tamper_metadata(root: Path, change) -> None:
    path = root / "t-v0/data/metadata.json"
    metadata = json.loads(path.read_text())
    carried = json.loads(metadata[METADATA_KEY])
    change(carried)
    metadata[METADATA_KEY] = json.dumps(carried)
    path.write_text(json.dumps(metadata))


@pytest.mark.parametrize(
    ("change", "problem"),
    [
        (lambda c: c.update(files=[]), "bad 'lfd_track' metadata (no files)"),
        (lambda c: c.update(episodes=[{"file": 5, "n_cases": 38}]), "an episode of no file"),
        (lambda c: c.update(episodes=5), "bad 'lfd_track' metadata"),
        (lambda c: c.update(episodes=[]), "episode 0 is not in its metadata"),
        (lambda c: c["files"][0].update(road_library={"x": 1}), "bad 'lfd_track' metadata"),
        (lambda c: c.update(n_memory=2), "memory settings do not fit 2 memory inputs"),
        (lambda c: c.update(version=9), "format version 9"),
        (lambda c: c["episodes"][0].update(n_cases=3), "episode 0 does not fit its metadata"),
    ],
)
def test_a_tampered_dataset_is_one_line(one_file_dataset, tmp_path, capsys, change, problem):
    root = tmp_path / "ds"
    shutil.copytree(one_file_dataset, root)
    _tamper_metadata(root, change)
    out = tmp_path / "c.json"
    code, err = _run(
        ["evolve", "--minari", "t-v0", "--datasets-path", str(root), "--out", str(out)], capsys
    )
    assert code == 1 and err.count("\n") == 1, err
    assert err.startswith("lfd-track evolve: Minari dataset t-v0: ") and problem in err
    assert not out.exists()


def test_a_truncated_storage_is_one_line(one_file_dataset, tmp_path, capsys):
    root = tmp_path / "ds"
    shutil.copytree(one_file_dataset, root)
    storage = root / "t-v0/data/main_data.hdf5"
    storage.write_bytes(storage.read_bytes()[:5000])
    out = tmp_path / "c.json"
    code, err = _run(
        ["evolve", "--minari", "t-v0", "--datasets-path", str(root), "--out", str(out)], capsys
    )
    assert code == 1 and err.count("\n") == 1 and "t-v0: cannot be read" in err
    assert not out.exists()


def test_an_impossible_road_value_in_the_storage_is_one_line(one_file_dataset, tmp_path, capsys):
    import h5py

    root = tmp_path / "ds"
    shutil.copytree(one_file_dataset, root)
    with h5py.File(root / "t-v0/data/main_data.hdf5", "a") as storage:
        storage["episode_0/observations"][3, 0] = 7.0
    with pytest.raises(LfdTrackError, match=r"episode 0: road value 7 outside \[-1, 1\]"):
        cases_from_minari("t-v0", datasets_path=root)


def test_a_datasets_folder_that_is_a_file_is_one_line(sample, tmp_path):
    (tmp_path / "file").write_text("mine")
    with pytest.raises(LfdTrackError, match="file: the Minari datasets folder is not a folder"):
        export_minari(sample[:1], "x-v0", datasets_path=tmp_path / "file")
    assert (tmp_path / "file").read_text() == "mine"
