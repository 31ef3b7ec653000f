"""Which picture files the plots can write, checked before any work is done."""

from __future__ import annotations

from pathlib import Path

from grouptron.errors import GrouptronError
from grouptron.io import refuse_folder

ANIMATIONS = (".gif", ".mp4")


def picture_formats() -> tuple[str, ...]:
    """The file suffixes matplotlib can write a still picture in (``.png``, ``.pdf``, ...)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    return tuple(f".{name}" for name in FigureCanvasAgg(Figure()).get_supported_filetypes())


def check_picture_path(
    path: Path,
    *,
    animation: bool = False,
    option: str = "--out",
    inputs: tuple[str | Path, ...] = (),
) -> None:
    """Refuse an output path the plot could not write, before the forecasts are computed:
    a folder, an input file, or a suffix that is not a picture format (an animation: ``.gif``
    or ``.mp4``)."""
    refuse_folder(path, inputs=inputs)
    suffix = path.suffix.lower()
    if animation:
        if suffix not in ANIMATIONS:
            raise GrouptronError(
                f"{option} {path}: an animation (--until) is written as .gif or .mp4"
            )
        return
    formats = picture_formats()
    if suffix not in formats:
        raise GrouptronError(
            f"{option} {path}: a picture needs one of the suffixes {', '.join(sorted(formats))}"
        )
