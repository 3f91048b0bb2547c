import numpy as np
import pytest

from lfd_track.learning.fitness import category_weights, imitation_fitness, population_outputs
from lfd_track.policy.mlp import mlp_forward


def literal_algorithm_3(weights, inputs, actions, threshold=0.4):
    """Algorithm 3 transcribed line by line: per network, per training case."""
    counts = {a: int(np.sum(actions == a)) for a in range(3)}
    result = []
    for w in weights:
        fitness = 0.0
        for x, expected in zip(inputs, actions, strict=True):
            actual = mlp_forward(w, x)
            winning = actual[expected]
            others = [i for i in range(3) if i != expected]
            difference1 = winning - actual[others[0]]
            difference2 = winning - actual[others[1]]
            for difference in (difference1, difference2):
                if difference >= threshold:
                    fitness += 0.5 / counts[expected]
                else:
                    fitness += 0.5 * (difference / threshold) / counts[expected]
        result.append(1 - fitness / 3)
    return np.array(result)


@pytest.mark.parametrize("scale", [1.0, 8.0])
def test_matches_literal_transcription(scale):
    rng = np.random.default_rng(3)
    w = rng.uniform(-scale, scale, (12, 215))
    x = rng.uniform(-1, 1, (57, 40))
    actions = rng.choice(3, size=57, p=[0.8, 0.1, 0.1])
    ours = imitation_fitness(w, x, actions)
    np.testing.assert_allclose(ours, literal_algorithm_3(w, x, actions), atol=1e-12, rtol=0)
    # Large weights push some differences past the threshold and others strongly negative.
    out = mlp_forward(w, x)
    diffs = out[:, np.arange(57), actions][..., None] - out
    if scale > 1:
        assert (diffs >= 0.4).any() and (diffs < -0.4).any()


def test_categories_weigh_equally_regardless_of_size():
    rng = np.random.default_rng(4)
    w = rng.uniform(-2, 2, (5, 215))
    x = rng.uniform(-1, 1, (9, 40))
    actions = np.array([0, 0, 0, 1, 1, 2, 2, 2, 2])
    base = imitation_fitness(w, x, actions)
    # Repeating every forward case 10 times (the paper's 10:1 ratio) changes nothing.
    x_many = np.concatenate([np.repeat(x[:3], 10, axis=0), x[3:]])
    a_many = np.concatenate([np.repeat(actions[:3], 10), actions[3:]])
    np.testing.assert_allclose(imitation_fitness(w, x_many, a_many), base, atol=1e-12)


def test_bounds_and_direction():
    # A perfect separation on every case gives 0; the mirror image gives the worst value.
    x = np.zeros((3, 40))
    actions = np.array([0, 1, 2])
    w = np.zeros((1, 215))
    f = imitation_fitness(w, x, actions)  # all outputs equal: every difference 0
    assert f[0] == pytest.approx(1.0)
    x1 = np.ones((3, 40))
    w_perfect = np.zeros((1, 215))
    w_perfect[0, :200] = 1.0  # hidden nodes saturate near 1
    w_perfect[0, 200:205] = 10.0  # output 0 high, outputs 1 and 2 at 0.5
    f_fwd = imitation_fitness(w_perfect, x1[:1], np.array([0]))
    assert f_fwd[0] == pytest.approx(1 - 1 / 3)  # one category present: at most 1/3 earned


def test_rejects_bad_actions():
    with pytest.raises(ValueError, match="actions"):
        imitation_fitness(np.zeros((1, 215)), np.zeros((2, 40)), np.array([0, 3]))


def test_training_accuracy_counts_argmax_agreement():
    from lfd_track.learning.fitness import training_accuracy
    from lfd_track.policy.mlp import mlp_forward

    rng = np.random.default_rng(3)
    weights = rng.uniform(-1, 1, 215)
    inputs = rng.uniform(-1, 1, (50, 40))
    predicted = mlp_forward(weights, inputs).argmax(axis=1)
    actions = predicted.copy()
    actions[:10] = (actions[:10] + 1) % 3  # ten deliberate disagreements
    assert training_accuracy(weights, inputs, actions) == pytest.approx(0.8)


def reference_fitness(weights, inputs, actions, threshold=0.4):
    """The first vectorised version: ``mlp_forward`` per network, then the scoring as written."""
    outputs = mlp_forward(weights, inputs)  # (P, N, 3)
    others_of = np.array([[1, 2], [0, 2], [0, 1]])
    winning = np.take_along_axis(outputs, actions[None, :, None], axis=2)
    others = np.take_along_axis(outputs, others_of[actions][None], axis=2)
    diff = winning - others
    score = np.where(diff >= threshold, 0.5, 0.5 * (diff / threshold))
    return 1.0 - (score.sum(axis=2) @ category_weights(actions)) / 3.0


# Population sizes and case counts around every special case of the stacked kernel: one case,
# odd counts (last row recomputed), one network (padding), 40 x 150 (the GA), many rows (blocks).
SHAPES = [(1, 1), (1, 2), (1, 9), (2, 3), (3, 13), (7, 64), (40, 150), (40, 151), (13, 701)]


@pytest.mark.parametrize(("p", "n"), SHAPES)
@pytest.mark.parametrize("bias", [False, True])
def test_stacked_outputs_equal_mlp_forward_bit_for_bit(p, n, bias):
    rng = np.random.default_rng(p * 1000 + n)
    w = rng.uniform(-3, 3, (p, 223 if bias else 215))
    x = rng.uniform(-0.1, 1, (n, 40))
    np.testing.assert_array_equal(population_outputs(w, x, bias=bias), mlp_forward(w, x))


@pytest.mark.parametrize(("p", "n"), SHAPES)
def test_fitness_equals_reference_bit_for_bit(p, n):
    # Bit for bit, not approximately: GA tournaments compare fitnesses, so a last-bit change
    # would change which network wins and every generation after it.
    rng = np.random.default_rng(p + n)
    w = rng.uniform(-8, 8, (p, 215))
    x = rng.uniform(-0.1, 1, (n, 40))
    actions = rng.choice(3, size=n, p=[0.8, 0.1, 0.1])
    np.testing.assert_array_equal(
        imitation_fitness(w, x, actions), reference_fitness(w, x, actions)
    )


def test_fitness_rejects_wrong_weight_width():
    with pytest.raises(ValueError, match="weights"):
        imitation_fitness(np.zeros((2, 214)), np.zeros((3, 40)), np.array([0, 1, 2]))


def test_falls_back_to_mlp_forward_when_the_stacked_form_differs(monkeypatch):
    # Another BLAS may round the stacked products differently; the once-per-process probe must
    # then route every call to mlp_forward so the results stay bit-for-bit the same.
    from lfd_track.learning import fitness

    real = fitness._stacked_outputs

    def off_by_one_bit(weights, inputs, *, bias):
        out = real(weights, inputs, bias=bias)
        out[0, -1, 0] = np.nextafter(out[0, -1, 0], 2.0)
        return out

    monkeypatch.setattr(fitness, "_stacked_outputs", off_by_one_bit)
    monkeypatch.setattr(fitness, "_STACKED_MATCHES", {})
    rng = np.random.default_rng(8)
    w = rng.uniform(-3, 3, (40, 215))
    x = rng.uniform(-0.1, 1, (151, 40))
    np.testing.assert_array_equal(population_outputs(w, x, bias=False), mlp_forward(w, x))
    assert fitness._STACKED_MATCHES == {40: False}
