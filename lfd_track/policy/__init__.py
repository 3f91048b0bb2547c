"""The policy side: the 40-5-3 sigmoid MLP (:mod:`.mlp`) and its Elman variant (:mod:`.elman`),
the per-region inputs it reads (:mod:`.features`: road values, optionally colours), its memory
inputs (:mod:`.memory`) and the controller file (:mod:`.controller`).

Only the network is re-exported here, so that a commander importing it does not import the
controller file's readers.
"""

from .mlp import LAYER_SIZES, mlp_forward, n_weights, select_action

__all__ = ["LAYER_SIZES", "mlp_forward", "n_weights", "select_action"]
