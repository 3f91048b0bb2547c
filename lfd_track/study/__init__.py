"""Studies: many conditions x matched seeds of the paper protocol, pooled with intervals.

``lfd-track study STUDY.toml --out DIR`` reads a study file (:mod:`.spec`), runs one benchmark
job per (condition, seed) on local processes or Ray (:mod:`.run`, :mod:`.jobs`), and pools the
results into ``study.json``, ``study.md`` and ``study.png`` (:mod:`.summary`).
"""

from .spec import Condition, Job, Study, load_study
from .stats import rate_summary, wilson_interval

__all__ = ["Condition", "Job", "Study", "load_study", "rate_summary", "wilson_interval"]
