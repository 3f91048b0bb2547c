"""The neural controller: the 40-5-3 sigmoid MLP and action selection."""

from .mlp import LAYER_SIZES, mlp_forward, n_weights, select_action

__all__ = ["LAYER_SIZES", "mlp_forward", "n_weights", "select_action"]
