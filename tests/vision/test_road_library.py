"""Algorithm 1 behaviours: strict threshold, caps, least-used eviction, protection, ties."""

import json
import warnings

import numpy as np
import pytest

from lfd_track.vision.grid import SAFE_BOX, safe_box_slices
from lfd_track.vision.histograms import centred_unit, similarity_matrix
from lfd_track.vision.road_library import RoadLibrary

BINS = 16


def spike(k: int) -> np.ndarray:
    """A model whose five histograms all peak at bin k: spikes at different bins are dissimilar."""
    m = np.zeros((5, BINS), np.float32)
    m[:, k] = 1.0
    return m


def near(base: np.ndarray, seed: int) -> np.ndarray:
    """A model very similar to ``base`` (similarity > 0.9)."""
    rng = np.random.default_rng(seed)
    return np.clip(base + rng.uniform(0, 0.05, base.shape), 0, 1).astype(np.float32)


def similarity(a: np.ndarray, b: np.ndarray) -> float:
    return float(similarity_matrix(centred_unit(a[None]), centred_unit(b[None]))[0, 0])


def frame_of(models: list[np.ndarray], counts: list[int]) -> np.ndarray:
    """Region histograms in which ``counts[i]`` regions are exact copies of ``models[i]``."""
    assert sum(counts) == 40
    return np.concatenate(
        [np.repeat(m[None], n, axis=0) for m, n in zip(models, counts, strict=True)]
    )


def test_threshold_is_strict():
    a = spike(2) + 0.3 * spike(3)
    b = spike(2) + 0.9 * spike(3)
    s = similarity(a, b)
    at = RoadLibrary(bins=BINS, similarity_threshold=s)
    at.learn_model(a)
    outcome = at.learn_model(b)
    assert outcome.new_type and at.n_types == 2  # similarity == threshold: not above it
    below = RoadLibrary(bins=BINS, similarity_threshold=float(np.nextafter(s, -1.0)))
    below.learn_model(a)
    outcome = below.learn_model(b)
    assert not outcome.new_type and below.type_sizes() == [2]
    assert outcome.similarity == pytest.approx(s, abs=0)


def test_default_threshold_joins_similar_and_splits_dissimilar():
    library = RoadLibrary(bins=BINS)
    base = np.linspace(0, 1, BINS, dtype=np.float32)[None].repeat(5, 0)
    first = library.learn_model(base)
    assert first.new_type and first.similarity is None and first.type_index == 0
    joined = library.learn_model(near(base, 1))
    assert not joined.new_type and joined.type_index == 0 and joined.similarity > 0.75
    split = library.learn_model(spike(0))
    assert split.new_type and split.type_index == 1 and split.similarity <= 0.75
    assert library.n_types == 2 and library.n_models == 3


def test_best_match_tie_goes_to_first_type():
    library = RoadLibrary(bins=BINS, similarity_threshold=0.75)
    library.learn_model(spike(1))
    library.learn_model(spike(5))
    # Identical copy of type 0's model appended to type 1 by hand: a tie between the two types.
    data = library.to_dict()
    data["types"][1]["examples"].append(
        {"selections": 0, "comparisons": 0, "model": spike(1).tolist()}
    )
    library = RoadLibrary.from_dict(data)
    outcome = library.learn_model(spike(1))
    assert outcome.best_type == 0 and outcome.type_index == 0
    values = library.road_values_from_histograms(frame_of([spike(1)], [40]))
    np.testing.assert_allclose(values, 1.0, atol=1e-12)
    assert library.example_statistics(0)[0][0] == 40  # type 0's example wins every region
    assert library.example_statistics(1)[1][0] == 0


def test_type_cap_evicts_least_used_type():
    library = RoadLibrary(bins=BINS, max_types=3)
    models = [spike(0), spike(4), spike(8)]
    for m in models:
        library.learn_model(m)
    library.road_values_from_histograms(frame_of(models, [30, 2, 8]))
    assert library.type_statistics() == [(30, 40), (2, 40), (8, 40)]
    outcome = library.learn_model(spike(12))
    assert outcome.new_type and outcome.evicted_type == 1 and outcome.type_index == 2
    assert library.n_types == 3
    remaining = library.models()
    np.testing.assert_array_equal(remaining[0], spike(0))
    np.testing.assert_array_equal(remaining[1], spike(8))  # order kept, new type appended
    np.testing.assert_array_equal(remaining[2], spike(12))


def test_type_frequency_uses_own_comparisons_since_entry():
    library = RoadLibrary(bins=BINS, max_types=2)
    library.learn_model(spike(0))
    library.road_values_from_histograms(frame_of([spike(0)], [40]))  # type 0: 40/40
    library.learn_model(spike(4))
    library.road_values_from_histograms(frame_of([spike(0), spike(4)], [30, 10]))
    # type 0: 70/80 = 0.875, type 1: 10/40 = 0.25 -> type 1 goes.
    assert library.type_statistics() == [(70, 80), (10, 40)]
    assert library.learn_model(spike(8)).evicted_type == 1


def test_counters_of_many_frames_add_up_before_they_are_read():
    library = RoadLibrary(bins=BINS, max_types=3)
    models = [spike(0), spike(4), spike(8)]
    for m in models:
        library.learn_model(m)
    for counts in ([30, 2, 8], [0, 40, 0], [10, 0, 30]):
        library.road_values_from_histograms(frame_of(models, counts))
    data = library.to_dict()
    assert [(t["selections"], t["comparisons"]) for t in data["types"]] == [
        (40, 120),
        (42, 120),
        (38, 120),
    ]
    assert library.example_statistics(2) == [(38, 120)]
    library.road_values_from_histograms(frame_of(models, [0, 0, 40]))
    # type 0 is now the least used (40/160 against 42/160 and 78/160)
    assert library.learn_model(spike(12)).evicted_type == 0
    assert library.type_statistics() == [(42, 160), (78, 160), (0, 0)]


def test_type_eviction_tie_goes_to_oldest():
    library = RoadLibrary(bins=BINS, max_types=3)
    models = [spike(0), spike(4), spike(8)]
    for m in models:
        library.learn_model(m)
    library.road_values_from_histograms(frame_of(models, [20, 10, 10]))
    assert library.learn_model(spike(12)).evicted_type == 1


def test_never_compared_type_is_protected():
    library = RoadLibrary(bins=BINS, max_types=3)
    library.learn_model(spike(0))
    library.learn_model(spike(4))
    library.road_values_from_histograms(frame_of([spike(0), spike(4)], [40, 0]))
    library.learn_model(spike(8))  # never compared: frequency undefined, must not go first
    # Type 1 has been compared and never selected (0/40): it goes, not the newcomer.
    assert library.learn_model(spike(12)).evicted_type == 1
    # Now types 1 (spike 8) and 2 (spike 12) are both uncompared; type 0 has 40/40 > 0 but is
    # the only compared one, so it goes before them.
    assert library.learn_model(spike(14)).evicted_type == 0


def test_all_uncompared_evicts_oldest():
    library = RoadLibrary(bins=BINS, max_types=2)
    library.learn_model(spike(0))
    library.learn_model(spike(4))
    assert library.learn_model(spike(8)).evicted_type == 0


def test_example_cap_evicts_least_used_example_of_matched_type():
    library = RoadLibrary(bins=BINS, max_examples=3)
    base = np.linspace(0, 1, BINS, dtype=np.float32)[None].repeat(5, 0)
    examples = [base, near(base, 1), near(base, 2)]
    for m in examples:
        library.learn_model(m)
    library.learn_model(spike(0))  # a second type, untouched by the eviction below
    assert library.type_sizes() == [3, 1]
    library.road_values_from_histograms(frame_of([*examples, spike(0)], [10, 3, 20, 7]))
    assert library.example_statistics(0) == [(10, 40), (3, 40), (20, 40)]
    outcome = library.learn_model(near(base, 3))
    assert not outcome.new_type and outcome.type_index == 0 and outcome.evicted_example == 1
    assert library.type_sizes() == [3, 1]
    np.testing.assert_array_equal(library.models()[1], examples[2])
    np.testing.assert_array_equal(library.models()[2], near(base, 3))
    assert library.example_statistics(0)[2] == (0, 0)


def test_example_eviction_protects_uncompared_and_ties_to_oldest():
    library = RoadLibrary(bins=BINS, max_examples=3)
    base = np.linspace(0, 1, BINS, dtype=np.float32)[None].repeat(5, 0)
    a, b = base, near(base, 1)
    library.learn_model(a)
    library.learn_model(b)
    library.road_values_from_histograms(frame_of([a, b], [20, 20]))
    library.learn_model(near(base, 2))  # uncompared third example
    # a and b tie at 0.5: the oldest (a) goes; the uncompared one stays.
    assert library.learn_model(near(base, 3)).evicted_example == 0


def test_learning_does_not_touch_statistics_and_empty_library_gives_zeros(frames):
    library = RoadLibrary()
    assert np.all(library.road_values(frames[0]) == 0.0)
    library.learn(frames[0])
    library.learn(frames[1])
    assert all(c == 0 for _, c in library.type_statistics())
    library.road_values(frames[0], update_statistics=False)
    assert all(c == 0 for _, c in library.type_statistics())
    library.road_values(frames[0])
    assert all(c == 40 for _, c in library.type_statistics())


def test_safe_box_model_uses_the_bottom_centre_patch(frames):
    library = RoadLibrary()
    frame = frames[0].copy()
    model = library.safe_box_model(frame)
    rows, cols = safe_box_slices()
    assert (rows.start, rows.stop, cols.start, cols.stop) == (430, 480, 295, 345)
    assert SAFE_BOX == (295, 430, 50, 50)
    frame[:430] = 0  # outside the box: no effect
    frame[:, :295] = 0
    np.testing.assert_array_equal(library.safe_box_model(frame), model)
    frame[479, 344] = 255 - frame[479, 344]  # the box's last pixel: an effect
    assert not np.array_equal(library.safe_box_model(frame), model)


def test_one_safe_box_everywhere():
    """SAFE_BOX means one thing: the (x, y, w, h) rectangle of lfd_track.core.frame."""
    import importlib
    import pkgutil

    import lfd_track
    from lfd_track.core import frame as frame_module

    owners = []
    for info in pkgutil.walk_packages(lfd_track.__path__, "lfd_track."):
        if info.name.endswith("__main__") or info.name.startswith(
            ("lfd_track.web", "lfd_track.hardware")
        ):
            continue  # optional stacks (neither names the safe box) and the CLI entry point
        module = importlib.import_module(info.name)
        if hasattr(module, "SAFE_BOX"):
            owners.append(info.name)
            assert module.SAFE_BOX is frame_module.SAFE_BOX, info.name
    assert "lfd_track.render.camera" not in owners
    assert set(owners) >= {"lfd_track.core.frame", "lfd_track.vision.grid"}


def test_to_dict_from_dict_is_lossless_through_json(frames):
    library = RoadLibrary(bins=32, max_types=4, max_examples=3)
    for frame in frames[:10]:
        library.learn(frame)
        library.road_values(frame)
    data = json.loads(json.dumps(library.to_dict()))
    copy = RoadLibrary.from_dict(data)
    assert copy.to_dict() == library.to_dict()
    np.testing.assert_array_equal(copy.models(), library.models())
    np.testing.assert_array_equal(copy.road_values(frames[11]), library.road_values(frames[11]))
    assert copy.to_dict() == library.to_dict()  # statistics advanced identically


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d.pop("bins"), "missing key 'bins'"),
        (lambda d: d.update(version=9), "version"),
        (lambda d: d["types"][0]["examples"][0].update(model=[[0.0] * 32] * 4), "shape"),
        (lambda d: d["types"][0]["examples"][0].update(selections=-1), "non-negative"),
        (lambda d: d["types"][0].update(examples=[]), "examples"),
        # Integers beyond a float and finite values beyond float32: a bare OverflowError or a
        # numpy overflow warning before.
        (lambda d: d.update(similarity_threshold=10**400), r"similarity_threshold must lie in"),
        (lambda d: d["types"][0]["examples"][0]["model"][0].__setitem__(0, 10**400), "numbers"),
        (lambda d: d["types"][0]["examples"][0]["model"][0].__setitem__(0, 1e39), r"\[0, 1\]"),
    ],
)
def test_from_dict_rejects_bad_data(frames, edit, match):
    library = RoadLibrary()
    library.learn(frames[0])
    data = library.to_dict()
    edit(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no numpy warning on the way to the error
        with pytest.raises(ValueError, match=match):
            RoadLibrary.from_dict(data)


@pytest.mark.parametrize("shape", [(241, 320, 3), (240, 324, 3), (480, 640), (480, 640, 4)])
def test_frame_shape_checked(shape):
    # The 8 x 5 grid must divide the frame (a half-size camera's 240 x 320 does).
    with pytest.raises(ValueError, match="shape"):
        RoadLibrary().road_values(np.zeros(shape, np.uint8))


@pytest.mark.parametrize(
    "threshold, match",
    [
        ("0.5", "similarity_threshold must be a number"),
        (None, "similarity_threshold must be a number"),
        (True, "similarity_threshold must be a number"),
        ([0.5], "similarity_threshold must be a number"),
        (1.5, r"similarity_threshold must be in \[-1, 1\]"),
        (float("nan"), r"similarity_threshold must be in \[-1, 1\]"),
        (10**400, r"similarity_threshold must be in \[-1, 1\]"),
    ],
)
def test_constructor_names_a_bad_similarity_threshold(threshold, match):
    with pytest.raises(ValueError, match=match):
        RoadLibrary(similarity_threshold=threshold)


def test_constructor_takes_numpy_and_integer_thresholds():
    assert RoadLibrary(similarity_threshold=np.float32(0.5)).similarity_threshold == 0.5
    assert RoadLibrary(similarity_threshold=1).similarity_threshold == 1.0
