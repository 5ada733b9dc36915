"""Studies on top of the impact laws and the simulator: dissipation landscapes, the failure
atlas, the reproduction of the paper's examples and figures, and their plots; coefficients
fitted to observed trajectories (:mod:`convimpact.studies.fitting`)."""

#: names re-exported on first use (their modules load scipy and the simulator)
_LAZY = {
    "fit_coefficients": "fitting", "CoefficientFit": "fitting", "FitError": "fitting",
    "Observations": "fitting_model", "synthetic_observations": "fitting_model",
    "with_coefficients": "fitting_model",
}

__all__ = sorted(_LAZY)


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))
