"""The ``fresh_felt`` map's update keeps a table of links between steps; these tests hold it to a
straightforward reference that measures every pair afresh at every step (a full distance table
among the felt near the axle, the strip grown hop by hop, every map point measured against every
place of the path). Decisions (which points are on the rover's own strip, whether any felt is
fresh) must be the same exactly, the inputs within 1e-9."""

import copy

import numpy as np
import pytest

from lfd_track.core.commands import Command
from lfd_track.core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from lfd_track.policy.memory import (
    CARPET_LEVEL,
    FELT_LEVEL,
    FULL_BEARING_RANGE_DEG,
    MAP_FRAMES,
    FreshFeltConfig,
    FreshFeltMemory,
    region_floor_points,
)

TOLERANCE = 1e-9
#: The fresh_felt maps of the committed goal studies, and two beyond them.
MAPS = {
    "chosen": FreshFeltConfig(),
    "round16": FreshFeltConfig(strip_picture_links=False),
    "round14-nearest": FreshFeltConfig.plain(
        strip_link_m=0.15, strip_from="nearest", blank_reach_m=1.0, bearing_range_deg=30.0
    ),
    "plain": FreshFeltConfig.plain(),
    "wide-links": FreshFeltConfig(
        strip_link_m=0.3, path_radius_m=0.0, reach_m=1.5, blank_reach_m=2.0
    ),
}


def reference_strip(config: FreshFeltConfig, points: np.ndarray, felt: np.ndarray) -> np.ndarray:
    """(N,) bool: the rover's own strip, every link measured now in a full table."""
    dist = np.hypot(points[:, 0], points[:, 1])
    candidates = np.flatnonzero((dist < 1.2) & (felt >= 0.5))
    on_strip = np.zeros(len(points), dtype=bool)
    if not len(candidates):
        return on_strip
    gap = points[candidates][:, None, :] - points[candidates][None, :, :]
    linked = np.einsum("ijk,ijk->ij", gap, gap) <= config.strip_link_m**2
    if config.strip_picture_links:  # regions of one frame that touch (side or corner)
        frame, region = np.divmod(candidates, N_REGIONS)
        row, column = np.divmod(region, GRID_COLUMNS)
        linked |= (
            (frame[:, None] == frame[None, :])
            & (np.abs(row[:, None] - row[None, :]) <= 1)
            & (np.abs(column[:, None] - column[None, :]) <= 1)
        )
    start = dist[candidates]
    seed_m = 0.3
    if config.strip_from == "nearest":
        seed_m = max(seed_m, float(start.min()) + config.strip_link_m)
    reached = start <= seed_m
    for _ in range(8):
        reached = reached | linked[reached].any(axis=0)
    on_strip[candidates[reached]] = True
    return on_strip


def reference_inputs(memory: FreshFeltMemory, last_bearing: float) -> np.ndarray:
    """The inputs of ``memory``'s map as it stands (its points, felt and path)."""
    cfg, points, felt, path = memory.config, memory._points, memory._felt, memory._path
    dist = np.hypot(points[:, 0], points[:, 1])
    strip = reference_strip(cfg, points, felt) if cfg.strip_link_m else True
    kept = 1.0
    if len(path):
        gap = points[:, None, :] - path[None, :, :]
        nearest = np.einsum("ijk,ijk->ij", gap, gap).min(axis=1)
        if cfg.visited_fade_m:
            kept = np.clip((np.sqrt(nearest) - cfg.path_radius_m) / cfg.visited_fade_m, 0, 1)
        else:
            kept = (nearest > cfg.path_radius_m**2).astype(np.float64)

    def weights(reach: float) -> np.ndarray:
        return felt * ((dist < reach) & (points[:, 0] > -0.05) & strip) * kept

    reach = cfg.reach_m
    w = weights(reach)
    if w.sum() < 1.0 and cfg.blank_reach_m:
        w = weights(cfg.blank_reach_m)
        reach = cfg.blank_reach_m if cfg.blank_distance == "blank_reach" else reach
    mass = w.sum()
    if mass < 1.0:
        return np.array([last_bearing if cfg.blank_bearing == "last" else 0.5, 0.0, 0.0])
    x, y = (w * points[:, 0]).sum() / mass, (w * points[:, 1]).sum() / mass
    bearing = np.arctan2(y, x)
    if cfg.bearing_range_deg == FULL_BEARING_RANGE_DEG:
        encoded = 0.5 * (1.0 + bearing / np.pi)
    else:
        encoded = np.clip(0.5 * (1.0 + bearing / np.radians(cfg.bearing_range_deg)), 0, 1)
    return np.array([encoded, min(1.0, mass / 20.0), min(1.0, np.hypot(x, y) / reach)])


def _episode(rng: np.random.Generator, steps: int) -> list[tuple[np.ndarray, int]]:
    """Road values of a strip wandering across the picture (with speckle), and commands."""
    out, centre = [], 3.5
    for _ in range(steps):
        centre = float(np.clip(centre + rng.normal(0, 0.8), -1, 8))
        columns = np.arange(GRID_COLUMNS)
        grid = np.clip(1.2 - 0.5 * np.abs(columns - centre), 0, 1)[None, :].repeat(GRID_ROWS, 0)
        grid = np.clip(grid + rng.normal(0, 0.15, grid.shape), 0, 1)
        command = int(rng.choice(3, p=[0.6, 0.2, 0.2]))
        out.append((grid.reshape(N_REGIONS), command))
    return out


def _check(memory: FreshFeltMemory, last_bearing: float) -> None:
    expected = reference_inputs(memory, last_bearing)
    np.testing.assert_allclose(memory.inputs(), expected, rtol=0, atol=TOLERANCE)
    assert (memory.inputs()[1] > 0) == (expected[1] > 0)  # fresh felt found: the same decision
    if memory.config.strip_link_m:
        dist = np.hypot(memory._points[:, 0], memory._points[:, 1])
        strip = reference_strip(memory.config, memory._points, memory._felt)
        np.testing.assert_array_equal(memory._own_strip(dist), strip)


@pytest.mark.parametrize("name", MAPS)
def test_the_map_gives_the_references_strip_and_inputs_at_every_step(name):
    """Two episodes (in the first the map is full after 25 frames and keeps dropping its
    oldest), every step checked, and every other step a view from the pose before (a copy of the
    map as it was, placed one command back and shown other values) checked too; the copy leaves
    the table of links it shares with the map as it was."""
    memory = FreshFeltMemory(MAPS[name])
    rng = np.random.default_rng(sum(map(ord, name)))
    for steps in (MAP_FRAMES + 15, 10):  # the map full and dropping its oldest; a reset
        memory.reset()
        for step, (values, command) in enumerate(_episode(rng, steps)):
            before = copy.copy(memory)
            last = memory.inputs()[0]
            memory.see(values)
            _check(memory, last)
            if step % 2:
                table = before._linked.copy()
                placed = copy.copy(before)
                placed.place_before(Command((command + step) % 3))
                placed.see(values[::-1])
                _check(placed, last)
                np.testing.assert_array_equal(before._linked, table)
            memory.note(command)


def test_pairs_one_link_length_apart_are_measured_again_at_every_step():
    """Felt in two regions whose floor points lie exactly one link apart (the link length is
    their distance): whether they are linked rests on the last bits of the distance as the
    moved map has it, so the pair is measured again every step, as the reference does, while
    the rover pivots and drives on."""
    points = region_floor_points()
    a, b = 3 * GRID_COLUMNS + 3, 2 * GRID_COLUMNS + 3  # one above the other, near the axle
    link = float(np.hypot(*(points[a] - points[b])))
    config = FreshFeltConfig.plain(strip_link_m=link)
    values = np.full(N_REGIONS, CARPET_LEVEL)
    values[[GRID_COLUMNS + 3, b, a, 4 * GRID_COLUMNS + 3]] = FELT_LEVEL
    memory = FreshFeltMemory(config)
    rng = np.random.default_rng(3)
    unsure = 0
    for _ in range(MAP_FRAMES + 10):
        last = memory.inputs()[0]
        memory.see(values)
        unsure = max(unsure, len(memory._unsure))
        _check(memory, last)
        memory.note(int(rng.choice(3)))
    assert unsure > 0
