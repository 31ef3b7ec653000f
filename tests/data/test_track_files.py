"""A track file of any kind as one description (``TrackFile``), its messages in the caller's
own terms."""

from __future__ import annotations

from pathlib import Path

import pytest

from grouptron.data.formats.spelling import FLAGS
from grouptron.data.formats.track_files import TrackFile, read_track_file
from grouptron.errors import GrouptronError
from tests.conftest import write_tracks


def test_a_layout_of_its_own_is_resampled_and_a_benchmark_file_read_as_it_is(
    tmp_path: Path,
) -> None:
    rows = [(10 * k, p, 0.4 * k, float(p)) for k in range(12) for p in (1, 2)]
    path = write_tracks(tmp_path / "walk.txt", rows)
    assert TrackFile(path).as_is and not TrackFile(path, units="cm").as_is
    table, bag = read_track_file(TrackFile(path))
    assert bag is None and table.frames_per_step == 10 and len(table.ped_id) == len(rows)
    resampled, _ = read_track_file(TrackFile(path, columns="frame,id,x,y", units="cm"))
    assert resampled.pos_m[:, 0].max() == pytest.approx(0.044)  # centimetres


def test_messages_name_the_options_as_the_caller_wrote_them(tmp_path: Path) -> None:
    both = TrackFile(tmp_path / "a.txt", fps=10.0, frames_per_step=5)
    with pytest.raises(GrouptronError, match=r"^fps and frames_per_step both set"):
        both.recording_format(5)
    flagged = TrackFile(tmp_path / "a.txt", fps=10.0, frames_per_step=5, spelling=FLAGS)
    with pytest.raises(GrouptronError, match=r"^--fps and --frames-per-step both set"):
        flagged.recording_format(5)
    with pytest.raises(GrouptronError, match=r"a ROS 2 bag: name the topic .* \(topic\)"):
        read_track_file(TrackFile(tmp_path / "a.mcap"))
