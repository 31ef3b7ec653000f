"""grouptron: group-aware pedestrian trajectory forecasting.

The package follows the data flow ``data -> groups -> model -> training/evaluation -> cli``.

Shape vocabulary used in docstrings and comments throughout:

    B  batch (samples)          N  agents / neighbours
    T  history steps (8)        H  prediction horizon (12)
    K  samples per prediction   Z  latent modes (25)
    G  groups                   D  features

A sample is one pedestrian (the *ego*) at one step ``t``; its history covers ``t-7..t`` and its
future ``t+1..t+12``. Every step is 0.4 s (the ETH/UCY convention).
"""

__version__ = "0.1.0"

__all__ = ["Forecast", "Predictor", "StreamSession", "__version__"]


def __getattr__(name: str) -> object:
    # The API pulls in PyTorch; import it on first use so `import grouptron` stays light.
    if name in ("Forecast", "Predictor", "StreamSession"):
        from grouptron.inference import predictor

        return getattr(predictor, name)
    raise AttributeError(f"module 'grouptron' has no attribute {name!r}")
