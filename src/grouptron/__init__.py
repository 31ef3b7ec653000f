"""grouptron: group-aware pedestrian trajectory forecasting.

Layers, each importing only those below it (docs/architecture.md; ``lint-imports`` checks):
``cli > ros2 > workflows > reporting > viz > inference > training > evaluation > baselines >
model > groups > data > presets > config > point_forecast > io, geometry, constants, devices >
errors``.

Shape letters used in docstrings and comments throughout (docs/vocabulary.md):

    B  batch of samples          S  samples of a whole set or scene
    N  agents / graph nodes      E  edges (neighbour rows, flat)
    R  rows of a track table     T  history steps (8)
    H  horizon steps (12)        K  sampled futures per sample
    Z  latent values (25)        M  latent values decoded per sample
    G  groups                    C  bootstrap clusters (time steps)
    D  features

A sample is one pedestrian (the *ego*) at one step ``t``; its history covers ``t-7..t`` and its
future ``t+1..t+12``. Every step is 0.4 s (the ETH/UCY convention).
"""

__version__ = "0.1.0"

__all__ = ["Forecast", "Predictor", "StreamSession", "__version__", "load_tracks"]


def __getattr__(name: str) -> object:
    # The API pulls in PyTorch; import it on first use so `import grouptron` stays light.
    if name in ("Forecast", "Predictor", "StreamSession"):
        from grouptron.inference import predictor

        return getattr(predictor, name)
    if name == "load_tracks":
        from grouptron.data.formats.track_files import load_tracks

        return load_tracks
    raise AttributeError(f"module 'grouptron' has no attribute {name!r}")
