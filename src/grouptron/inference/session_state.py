"""What a live session adapted to its site, kept in a folder and taken up after a restart:
the online radii (``online.json``) and the learnt weights in use with their card (``site/``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from grouptron.errors import GrouptronError
from grouptron.inference.online import OnlineCalibration
from grouptron.inference.site_model import load_site, save_site

ONLINE_STATE = "online.json"
"""A kept state's online radii."""
SITE_FOLDER = "site"
"""A kept state's learnt weights and their card (``site_model.save_site``)."""


def save_session_state(session: Any, folder: Path, site: bool = True) -> list[Path]:
    """Write the ``StreamSession``'s online radii and, with ``site``, its learner's weights in
    use and status (taken together; a running round is not waited for) to ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    written = []
    if session.online is not None:
        session.online.save(folder / ONLINE_STATE)
        written.append(folder / ONLINE_STATE)
    if session.learner is not None and site:
        model, status = session.learner.snapshot()
        source = getattr(session.predictor, "source", "")
        config = session.predictor.config
        written.append(save_site(folder / SITE_FOLDER, model, config, status, source))
    return written


def resume_session_state(session: Any, folder: Path) -> list[str]:
    """Take up in the ``StreamSession`` what :func:`save_session_state` kept in ``folder``
    (whichever of online radii and learning the session has on); one line where the state is
    another model's."""
    resumed = []
    if session.online is not None and (folder / ONLINE_STATE).is_file():
        online = OnlineCalibration.load(folder / ONLINE_STATE)
        if online.horizon != session.online.horizon:
            raise GrouptronError(
                f"{folder / ONLINE_STATE}: radii for {online.horizon} steps, the model "
                f"forecasts {session.online.horizon}: not this model's state"
            )
        session.online = online
        resumed.append("online radii")
    if session.learner is not None and (folder / SITE_FOLDER).is_dir():
        model, status = load_site(folder / SITE_FOLDER, getattr(session.predictor, "source", ""))
        session.learner.resume(model, status)
        resumed.append("learnt weights" if status.adapted else "learning status")
    return resumed
