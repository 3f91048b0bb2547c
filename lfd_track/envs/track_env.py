"""The simulated felt-track world as a Gymnasium environment: ``LfDTrack-v0``."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.envs.registration import EnvSpec

from ..core.camera_model import CameraModel
from ..core.commands import Command
from ..render.camera import CameraRenderer
from ..render.texture import MAX_TEXTURE_BYTES, GroundTexture, build_ground
from ..render.topdown import draw_topdown
from ..world.dimensions import ROVER_BODY_WIDTH_M
from ..world.episode import EpisodeTracker, reference_step_count
from ..world.loops import LOOPS_PER_SPLIT, drawn_split
from ..world.rover import Rover
from ..world.track import Track, build_track, load_track, loop_track
from ..world.track_file import MAX_TRACK_SIZE_M
from .presets import Preset, load_preset
from .window import TopDownWindow, keys_to_action

#: Step budget per episode as a multiple of the commands an ideal driver needs (see
#: ``world/episode.py``: ``reference_step_count``).
BUDGET_FACTOR = 3.0


class LfDTrackEnv(gym.Env):
    """A tracked rover with a phone camera on a light-blue felt trail laid on brown carpet.

    ## Description
    The world of the paper *Learning from Demonstration for Encapsulated Evolution of Robotic
    Controllers*: a Rover 5 tank chassis (pymunk, skid-steer treads) drives on felt strips; a phone
    camera 0.31 m above the floor, pitched 30° down, sees 0.25–1.84 m ahead. The agent sees only the
    camera image and chooses one of the paper's three discrete commands, each held for one control
    period (0.4 s by default).

    ## Action Space
    ``Discrete(3)``:

    | Num | Action  | Effect (paper calibration)                  |
    |-----|---------|---------------------------------------------|
    | 0   | forward | both treads forward, ≈ 0.10 m per command   |
    | 1   | left    | pivot counter-clockwise, ≈ 23° per command  |
    | 2   | right   | pivot clockwise, ≈ 23° per command          |

    ``step`` takes any integer the space contains (``int``, numpy integers, 0-d integer arrays);
    anything else raises ``ValueError``, booleans included (``Discrete.contains(True)`` is True
    because a Python bool is an int, but ``True`` is no command).

    ## Observation Space
    ``Box(0, 255, (480, 640, 3), uint8)``: the phone camera's RGB frame (rows top to bottom);
    ``(240, 320, 3)`` with ``[camera] scale = 0.5`` (preset ``paper_fast``: the same view).

    | Property     | Value                                                         |
    |--------------|---------------------------------------------------------------|
    | resolution   | 640 × 480, vertical FOV 41°, horizontal ≈ 53°                |
    | mount        | 0.31 m above the pivot centre, pitched 30° down               |
    | floor seen   | bottom row ≈ 0.25 m ahead, top row ≈ 1.84 m ahead            |
    | effects      | auto-exposure with lag, white-balance jitter, noise, vignette |

    ## Rewards
    Progress in metres along the centreline since the last step (negative when going back), and
    −1 on failure.

    ## Starting State
    On the centreline at the start, facing the driving direction: for a loop on its start corner
    (``start_corner``, default the file's first vertex — corner 4 of the testing track), for an
    open track ``episode.start_offset_m`` from its first end. Textures, lighting, exposure and motor
    asymmetry are drawn from the seed.

    ## Episode End
    Terminated on success (every corner negotiated and the end reached: open track within 0.40 m
    of the far end; loop back across the start) or failure (``"reversed"``: progress fell more than
    0.30 m below its maximum; ``"off_track"``: both treads completely off the felt). Truncated after
    ``max_steps`` commands (default 3× the commands an ideal driver needs, pivots included);
    ``env.spec.max_episode_steps`` states the same number for an env made with ``gym.make``.
    Calling ``step`` after the episode ended raises ``RuntimeError`` (call ``reset``), unless the
    env was made with ``continue_after_end=True`` (a demonstration protocol that is not one
    episode: the human drives on past the far end and turns round).

    ## Info
    ``pose`` (x, y, theta), ``progress_m``, ``lap_fraction``, ``corners_reached`` and
    ``corners_negotiated`` (labels in the order met), ``on_felt`` (left, right tread),
    ``failure`` (None, ``"reversed"`` or ``"off_track"``), ``failed_corner``, ``success``,
    ``safe_box_on_felt``, ``step``, ``max_steps``, ``track`` (the track's name: the file's
    ``name``, or ``"random:<split>:<index>"`` for a procedural loop).

    ## Arguments
    ``gym.make("LfDTrack-v0", track="testing", reverse=False, start_corner=None, preset="paper",
    render_mode=None, max_steps=None, continue_after_end=False)``

    * ``track``: shipped track name (``testing``, ``training``, ``sbend``), a path to a TOML file,
      one procedural loop (``"random:test:17"``: split and index, ``tracks/README.md``), or
      ``"random"`` for a new loop of the train split at every ``reset`` (``"random:validation"``,
      ``"random:test"``: of that split). The loop's index is drawn from the env's ``np_random``
      (a stream spawned after the world's, physics' and sensor's, so they are those of a fixed
      track), and the step budget, episode rules and ground follow the loop; before the first
      ``reset`` ``env.track`` is loop 0 of the split, and ``env.spec.max_episode_steps`` is None
      (the budget is the loop's: ``info["max_steps"]``). Such an env takes no ``start_corner``.
    * ``reverse``: drive the track against its file order (testing: clockwise; training:
      direction 2).
    * ``start_corner``: label of the corner to start on (loops only), ``"1"`` or ``1``.
    * ``preset``: ``paper`` (default), ``randomized`` or a path to a preset TOML file.
    * ``render_mode``: ``"rgb_array"`` returns a top-down picture (track, rover, camera footprint,
      trajectory); ``"human"`` shows that picture in a window after every ``reset`` and ``step``,
      at most ``render_fps`` (10) a second, and ``render()`` returns None. The window needs
      pygame (``pip install 'lfd-track[play]'``; without it the env is refused in one line naming
      that command); ``close()`` closes it.
    * ``max_steps``: override the step budget (a positive integer).
    * ``continue_after_end``: allow ``step`` after the episode ended.

    ``get_keys_to_action()`` is the key map of ``gymnasium.utils.play.play``: up arrow or W
    forward, left arrow or A left, right arrow or D right (``docs/environment.md`` gives the call).

    ``reset(options=...)`` accepts ``{"pose": (x [m], y [m], theta [rad])}`` to start elsewhere:
    three finite numbers, with (x, y) on the painted floor (the felt plus the preset's margin).
    Any other option, or a bad argument, raises ``ValueError``/``TypeError`` at once.

    ## Version History
    * v0: initial release.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 10}
    _spec: EnvSpec | None = None

    def __init__(
        self,
        track: str | Path = "testing",
        reverse: bool = False,
        start_corner: str | None = None,
        preset: str | Path | Preset = "paper",
        render_mode: str | None = None,
        max_steps: int | None = None,
        continue_after_end: bool = False,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None")
        if not isinstance(track, (str, Path)):
            raise TypeError(f"track must be a track name or a path, got {track!r}")
        if not isinstance(preset, (str, Path, Preset)):
            raise TypeError(f"preset must be a preset name, a path or a Preset, got {preset!r}")
        reverse = _flag("reverse", reverse)
        self.continue_after_end = _flag("continue_after_end", continue_after_end)
        if max_steps is not None and (
            isinstance(max_steps, (bool, np.bool_))
            or not isinstance(max_steps, (int, np.integer))
            or max_steps < 1
        ):
            raise ValueError(f"max_steps must be a positive integer or None, got {max_steps!r}")
        if start_corner is not None:
            if isinstance(start_corner, (bool, np.bool_)) or not isinstance(
                start_corner, (str, int, np.integer)
            ):
                raise TypeError(
                    f"start_corner must be a corner label or None, got {start_corner!r}"
                )
            start_corner = str(start_corner)  # labels are strings; 1 means "1"
        self.render_mode = render_mode
        # The window's pygame is loaded here, so a missing play extra refuses the env at once.
        self._window = (
            TopDownWindow(self.metadata["render_fps"]) if render_mode == "human" else None
        )
        # "random" or "random:<split>": a new loop of that split at every reset (CarRacing's way).
        self.loop_split: str | None = drawn_split(track)
        self._reverse = reverse
        if self.loop_split is not None and start_corner is not None:
            raise ValueError(
                f"start_corner: track '{track}' draws a new loop every episode and starts on its"
                " corner 1; name one loop (random:<split>:<index>) to start elsewhere"
            )
        self._max_steps_arg = int(max_steps) if max_steps is not None else None
        self.base_preset: Preset = preset if isinstance(preset, Preset) else load_preset(preset)
        self.preset = self.base_preset
        cam = self.preset.camera
        self.observation_space = spaces.Box(
            0, 255, (cam.frame_height_px, cam.frame_width_px, 3), np.uint8
        )
        self.action_space = spaces.Discrete(3)
        if self.loop_split is not None:
            # Any loop's felt fits the floor square, so one check covers every loop drawn.
            _check_ground_fits(_floor_square(f"random:{self.loop_split}"), self.base_preset)
            first = loop_track(self.loop_split, 0, reverse=reverse)  # until the first reset
        else:
            first = load_track(track, reverse=reverse, start_corner=start_corner)
        self._use_track(first)
        self._ground: GroundTexture | None = None
        self._world_seed: int | None = None  # the seed the built world was drawn from, if any
        self._rover: Rover | None = None
        self._renderer: CameraRenderer | None = None
        self._camera_model: CameraModel | None = None
        self._physics_rng: np.random.Generator | None = None
        self._sensor_rng: np.random.Generator | None = None
        self._trajectory: list[np.ndarray] = []
        self._steps = 0
        self._last_pose = np.zeros(3)
        self._safe_box_on_felt = False
        self._frame: np.ndarray | None = None
        self._ended = False

    def _use_track(self, track: Track) -> None:
        """Make ``track`` the env's track: its episode rules, step budget and checks."""
        rover_cfg = self.base_preset.rover
        ideal = reference_step_count(
            track,
            rover_cfg.forward_speed_mps * rover_cfg.control_period_s,
            rover_cfg.pivot_rate_radps * rover_cfg.control_period_s,
        )
        budget = self._max_steps_arg
        self.max_steps = budget if budget is not None else int(BUDGET_FACTOR * ideal)
        rules = self.base_preset.episode
        if not track.closed and (track.length_m <= rules.start_offset_m + rules.end_margin_m):
            raise ValueError(
                f"track '{track.name}' ({track.length_m:.2f} m) is too short for the"
                f" episode rules: it starts {rules.start_offset_m} m in and ends"
                f" {rules.end_margin_m} m before the far end"
            )
        if self.loop_split is None:
            _check_ground_fits(track, self.base_preset)
        self.track: Track = track
        self.episode = EpisodeTracker(track, rules)

    # ------------------------------------------------------------------------------------
    def _build_world(self, world_rng: np.random.Generator) -> None:
        preset = self.preset
        self._ground = build_ground(self.track, preset.appearance, preset.lighting, world_rng)
        self._rover = Rover(preset.rover)
        self._renderer = CameraRenderer(preset.camera, preset.sensor)
        self._camera_model = self._renderer.model  # the same lens; one extrinsics cache

    def _check_felt(self) -> tuple[bool, bool]:
        """Whether each tread touches the felt at the rover's pose (returned) and whether the
        camera's safe box lies wholly on it (kept for the info dict): one test of all points."""
        assert self._rover is not None and self._camera_model is not None  # built by reset()
        treads = self._rover.tread_points()  # (2, K, 2)
        k = treads.shape[1]
        box = self._camera_model.safe_box_floor_polygon(self._last_pose)
        on = self.track.on_felt(np.concatenate([treads.reshape(-1, 2), box]))
        self._safe_box_on_felt = bool(on[2 * k :].all())
        return bool(on[:k].any()), bool(on[k : 2 * k].any())

    def _info(self) -> dict[str, Any]:
        st = self.episode.state
        pose = self._last_pose
        return {
            "pose": (float(pose[0]), float(pose[1]), float(pose[2])),
            "progress_m": st.progress_m,
            "lap_fraction": self.episode.lap_fraction(),
            "corners_reached": list(st.corners_reached),
            "corners_negotiated": list(st.corners_negotiated),
            "on_felt": st.on_felt,
            "failure": st.failure,
            "failed_corner": self.episode.failed_corner,
            "success": st.success,
            "safe_box_on_felt": self._safe_box_on_felt,
            "step": self._steps,
            "max_steps": self.max_steps,
            "track": self.track.name,
        }

    # ------------------------------------------------------------------------------------
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode. ``options`` may hold ``pose`` (x, y, theta) to start elsewhere."""
        start = _start_pose_option(options)
        super().reset(seed=seed)
        # Independent streams so that, e.g., changing sensor noise never changes the physics.
        world_rng, physics_rng, sensor_rng = self.np_random.spawn(3)
        rebuild = self._ground is None or seed is not None or self.base_preset.randomized
        if self.loop_split is not None:
            # A fourth stream, spawned after the three above, so they stay what they were.
            (loop_rng,) = self.np_random.spawn(1)
            index = int(loop_rng.integers(LOOPS_PER_SPLIT))
            self._use_track(loop_track(self.loop_split, index, reverse=self._reverse))
            rebuild = True
        # The world is a function of the seed (and the track): a reset with the seed of the world
        # already built keeps it instead of painting the same floor again.
        same_world = self.loop_split is None and seed is not None and seed == self._world_seed
        if rebuild and not same_world:
            self.preset = self.base_preset.sample(world_rng)
            self._build_world(world_rng)
        if rebuild:
            self._world_seed = None if self.loop_split is not None else seed
        assert self._ground is not None and self._rover is not None and self._renderer is not None
        self._physics_rng, self._sensor_rng = physics_rng, sensor_rng
        pose = self.episode.start_pose()
        if start is not None:
            xmin, ymin, xmax, ymax = self.track.bounds(self.preset.appearance.margin_m)
            if not (xmin <= start[0] <= xmax and ymin <= start[1] <= ymax):
                raise ValueError(
                    f"options['pose'] ({start[0]:g}, {start[1]:g}) is off the painted floor"
                    f" x in [{xmin:.2f}, {xmax:.2f}], y in [{ymin:.2f}, {ymax:.2f}] m"
                )
            pose = start
        self._rover.reset(tuple(pose), physics_rng)
        # Sensor noise and white-balance pools belong to the world: redrawn when it is rebuilt.
        self._renderer.reset(sensor_rng, new_pools=rebuild)
        self._last_pose = self._rover.pose.copy()
        self._steps = 0
        self.episode.reset(self._last_pose, self._check_felt())
        self._trajectory = [self._last_pose[:2].copy()]
        self._frame = self._renderer.render(self._ground, self._last_pose, sensor_rng)
        self._ended = False
        if self.render_mode == "human":
            self.render()
        return self._frame, self._info()

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if (
            self._rover is None
            or self._renderer is None
            or self._ground is None
            or self._physics_rng is None
            or self._sensor_rng is None
        ):
            raise RuntimeError("call reset() before step()")
        if self._ended and not self.continue_after_end:
            raise RuntimeError(
                "the episode has ended (terminated or truncated): call reset() before step()"
                " (or make the env with continue_after_end=True)"
            )
        # Discrete.contains(True) is True (a Python bool is an int) while it already refuses
        # numpy bools; a bool is refused here too, so True never quietly means "left".
        if isinstance(action, bool) or not self.action_space.contains(action):
            raise ValueError(
                f"invalid action {action!r}: expected 0 (forward), 1 (left) or 2 (right)"
            )
        before = self.episode.state.progress_m
        previous_pose = self._last_pose
        self._rover.step(int(Command(int(action))), self._physics_rng)
        self._last_pose = self._rover.pose.copy()
        self._steps += 1
        st = self.episode.update(self._last_pose, self._check_felt())
        self._trajectory.append(self._last_pose[:2].copy())
        motion = self._last_pose - previous_pose
        self._frame = self._renderer.render(self._ground, self._last_pose, self._sensor_rng, motion)
        reward = st.progress_m - before
        if st.failure is not None:
            reward -= 1.0
        terminated = st.failure is not None or st.success
        truncated = not terminated and self._steps >= self.max_steps
        self._ended = terminated or truncated
        info = self._info()
        if self.render_mode == "human":
            self.render()
        return self._frame, float(reward), terminated, truncated, info

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            env_id = self.spec.id if self.spec is not None else "LfDTrack-v0"
            gym.logger.warn(
                "render() was called but the env has no render_mode, so it draws nothing; create"
                f' it with a render mode, e.g. gym.make("{env_id}", render_mode="rgb_array")'
            )
            return None
        if self._rover is None:
            picture = draw_topdown(self.track)
        else:
            picture = draw_topdown(
                self.track,
                pose=self._last_pose,
                trajectory=np.asarray(self._trajectory),
                footprint=self.camera_footprint(self._last_pose),
            )
        if self._window is not None:
            self._window.show(picture)
            return None
        return picture

    def close(self) -> None:
        """Close the window of ``render_mode="human"`` (if it is open)."""
        window = getattr(self, "_window", None)  # None too if __init__ refused its arguments
        if window is not None:
            window.close()
        super().close()

    def get_keys_to_action(self) -> dict[tuple[int, ...], int]:
        """Key map of ``gymnasium.utils.play.play``: pygame key codes -> action.

        Up arrow or W: 0 (forward); left arrow or A: 1 (left); right arrow or D: 2 (right).
        Needs pygame (the ``play`` extra). The paper's commands have no "stand still", so pass
        ``wait_on_player=True`` (the rover moves only while a key is held) and ``noop=0``: the
        action ``play`` sends for a combination the map lacks (two keys at once) is forward.
        """
        return keys_to_action()

    @property
    def spec(self) -> EnvSpec | None:
        """The spec ``gym.make`` gave this env; it states this env's own step budget.

        The budget depends on the track, so registration cannot state it; ``gym.make`` then
        records ``max_episode_steps=None`` here, and this fills in ``max_steps`` instead (unless a
        ``TimeLimit`` is asked for, which keeps its own limit on its own copy of the spec). With a
        new loop every episode (``track="random"``) it stays None: ``info["max_steps"]`` states
        each loop's budget.
        """
        return self._spec

    @spec.setter
    def spec(self, value: EnvSpec | None) -> None:
        budget = getattr(self, "max_steps", None)
        if getattr(self, "loop_split", None) is not None:
            budget = getattr(self, "_max_steps_arg", None)  # only a budget set for every loop
        if value is not None and value.max_episode_steps is None and budget is not None:
            value = dataclasses.replace(value, max_episode_steps=budget)
        self._spec = value

    # Convenience for drivers, demonstrators and tests (privileged state, not an observation).
    @property
    def rover_pose(self) -> np.ndarray:
        """Current (x, y, theta) of the rover [m, m, rad]."""
        return self._last_pose.copy()

    @property
    def camera_frame(self) -> np.ndarray | None:
        """The latest rendered camera frame (same array as the last observation)."""
        return self._frame

    def view_from(self, pose: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The camera frame a rover standing still at ``pose`` (x, y, theta) would see now, in
        this world with the camera's current exposure, without moving the rover or touching the
        episode's random streams (white balance and noise are drawn from ``rng``)."""
        if self._rover is None or self._renderer is None or self._ground is None:
            raise RuntimeError("call reset() before view_from()")
        return self._renderer.view(self._ground, np.asarray(pose, dtype=np.float64), rng)

    def camera_footprint(self, pose: np.ndarray) -> np.ndarray:
        """(N, 2) floor polygon [m] the camera sees from ``pose`` (x, y, theta); N = 4 for an
        ideal pinhole, more for a distorted lens (``CameraModel.footprint``)."""
        if self._camera_model is None:
            raise RuntimeError("call reset() before camera_footprint()")
        return self._camera_model.footprint(np.asarray(pose, dtype=np.float64))


def _flag(name: str, value: Any) -> bool:
    """A bool argument: True/False (numpy bools too), nothing that merely looks truthy."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def _start_pose_option(options: Any) -> np.ndarray | None:
    """The ``pose`` of reset's ``options`` as (3,) float64, None if absent; bad options raise."""
    if options is None:
        return None
    if not isinstance(options, dict):
        raise TypeError(f"options must be a dict or None, got {type(options).__name__}")
    unknown = sorted(str(k) for k in set(options) - {"pose"})
    if unknown:
        raise ValueError(f"unknown reset option '{unknown[0]}' (allowed: pose)")
    if "pose" not in options:
        return None
    try:
        pose = np.asarray(options["pose"], dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(
            f"options['pose'] must be (x, y, theta), got {options['pose']!r}"
        ) from None
    if pose.shape != (3,) or not np.isfinite(pose).all():
        raise ValueError(
            f"options['pose'] must be three finite numbers (x, y, theta), got {options['pose']!r}"
        )
    if abs(pose[2]) > 1e3:
        raise ValueError(f"options['pose'] heading {pose[2]:g} rad is not plausible")
    return pose


def _floor_square(name: str) -> Track:
    """A loop whose felt spans the whole floor a track may cover: the largest ground any drawn
    loop can need."""
    side = MAX_TRACK_SIZE_M - ROVER_BODY_WIDTH_M
    square = np.array([[0.0, 0.0], [side, 0.0], [side, side], [0.0, side]])
    return build_track(name, square, True, ROVER_BODY_WIDTH_M, {})


def _check_ground_fits(track: Track, preset: Preset) -> None:
    """Refuse at construction a track + preset whose ground texture would exceed the renderer's
    cap for some draw (finest ``metres_per_px``, widest ``margin_m`` the preset can draw)."""
    mpp = preset.appearance.metres_per_px
    margin = preset.appearance.margin_m
    for r in preset.randomization:
        if (r.section, r.key) == ("appearance", "metres_per_px"):
            mpp = min(mpp, r.low[0])
        elif (r.section, r.key) == ("appearance", "margin_m"):
            margin = max(margin, r.high[0])
    xmin, ymin, xmax, ymax = track.bounds(margin)
    size = (int(np.ceil((xmax - xmin) / mpp)) + 1) * (int(np.ceil((ymax - ymin) / mpp)) + 1) * 4
    if size > MAX_TEXTURE_BYTES:
        raise ValueError(
            f"track '{track.name}' with preset '{preset.name}' ({preset.source}) needs a"
            f" {size / 2**20:.0f} MiB ground texture, more than {MAX_TEXTURE_BYTES / 2**20:.0f} MiB:"
            " raise appearance.metres_per_px or lower appearance.margin_m"
        )
