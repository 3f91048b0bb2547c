"""One teaching loop for everything that teaches or drives (demonstration, trials, takeover).

A camera frame goes through a :class:`Perception` (the road library and its learning rule) to
road values; :class:`Commander` s propose commands (a scripted human, keys, a policy; ``None``
means no opinion); an :class:`Arbiter` decides who drives; :class:`Observer` s see every step
(recorder, trajectory, and the learner feed in :mod:`lfd_track.teaching.learner_feed`, kept out of
this package's namespace so that a policy importing a commander never imports a trainer). The demonstration, the benchmark trials and the online
methods are arrangements of :class:`TeachingLoop`, not copies of it.
"""

from .arbiter import Arbiter, Decision
from .commanders import Commander, PolicyCommander, QueueCommander
from .loop import TeachingLoop
from .observers import CallbackObserver, Observer, Recorder, TrajectoryObserver
from .perception import LEARNING_RULES, Percept, Perception
from .types import Moment, Step

__all__ = [
    "LEARNING_RULES",
    "Arbiter",
    "CallbackObserver",
    "Commander",
    "Decision",
    "Moment",
    "Observer",
    "Percept",
    "Perception",
    "PolicyCommander",
    "QueueCommander",
    "Recorder",
    "Step",
    "TeachingLoop",
    "TrajectoryObserver",
]
