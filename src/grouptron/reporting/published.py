"""Published most-likely FDE/ADE (metres) of the Grouptron paper's Tables I and II.

Keys are our split and subset names; "mean" is the paper's AVG column. Values are (FDE, ADE),
the order the paper prints them in.
"""

from __future__ import annotations

from typing import Final

TABLE_I: Final[dict[str, dict[str, tuple[float, float]]]] = {
    "Social-LSTM": {
        "eth": (2.35, 1.09),
        "hotel": (1.76, 0.79),
        "univ": (1.40, 0.67),
        "zara1": (1.00, 0.47),
        "zara2": (1.17, 0.56),
        "mean": (1.54, 0.72),
    },
    "Social-GAN": {
        "eth": (1.52, 0.81),
        "hotel": (1.61, 0.72),
        "univ": (1.26, 0.60),
        "zara1": (0.69, 0.34),
        "zara2": (1.84, 0.42),
        "mean": (1.18, 0.58),
    },
    "SoPhie": {
        "eth": (1.43, 0.70),
        "hotel": (1.67, 0.76),
        "univ": (1.24, 0.54),
        "zara1": (0.63, 0.34),
        "zara2": (0.78, 0.38),
        "mean": (1.15, 0.54),
    },
    "trajectron++": {
        "eth": (1.68, 0.71),
        "hotel": (0.46, 0.22),
        "univ": (1.07, 0.41),
        "zara1": (0.77, 0.30),
        "zara2": (0.59, 0.23),
        "mean": (0.91, 0.37),
    },
    "grouptron": {
        "eth": (1.56, 0.70),
        "hotel": (0.46, 0.21),
        "univ": (0.97, 0.38),
        "zara1": (0.76, 0.30),
        "zara2": (0.56, 0.22),
        "mean": (0.86, 0.36),
    },
}
"""Table I: ETH/UCY test sets (leave one location out)."""

TABLE_II: Final[dict[str, dict[str, tuple[float, float]]]] = {
    "trajectron++": {
        "univ": (1.07, 0.41),
        "univ-40": (1.17, 0.436),
        "univ-45": (1.24, 0.46),
        "univ-50": (1.25, 0.47),
    },
    "grouptron": {
        "univ": (0.97, 0.38),
        "univ-40": (1.00, 0.39),
        "univ-45": (1.04, 0.40),
        "univ-50": (1.07, 0.42),
    },
}
"""Table II: the UNIV test set and its dense subsets UNIV-N (at least N people in the scene)."""
