"""python -m dcs_torchrl.videos: the contact sheet."""
import cv2
import numpy as np
import pytest

from dcs_torchrl.videos import ArraySource
from dcs_torchrl.videos.__main__ import contact_sheet, main
from videos.files import COLORS, write_frames


def test_sheet_shows_first_middle_last_frame():
    video = np.stack([np.full((8, 8, 3), 10 * i, np.uint8) for i in range(5)])
    sheet = contact_sheet(ArraySource([video, video]), count=2, size=16, columns=2)
    assert sheet.shape == (16 + 16 + 4, 2 * (3 * 16 + 4), 3)  # label, frames, gap
    thumbs = sheet[16:32, :48].reshape(16, 3, 16, 3).mean(axis=(0, 2, 3))
    assert thumbs.tolist() == [0, 20, 40]


def test_cli_writes_a_png_of_a_folder(tmp_path, capsys):
    for i in range(3):
        write_frames(tmp_path / "videos" / f"clip{i}", 4, COLORS[i])
    out = tmp_path / "sheet.png"
    main(["--out", str(out), "--path", str(tmp_path / "videos"), "--count", "5", "--size", "24", "--columns", "1"])
    image = cv2.imread(str(out))
    assert image.shape == (3 * (16 + 24 + 4), 3 * 24 + 4, 3)
    assert "3 of 3 videos" in capsys.readouterr().err


def test_cli_embedded_val(tmp_path):
    out = tmp_path / "val.png"
    main(["--out", str(out), "--split", "val", "--count", "1", "--size", "16"])
    assert cv2.imread(str(out)).shape == (16 + 16 + 4, 2 * (3 * 16 + 4), 3)


def test_cli_rejects_bad_options(tmp_path):
    with pytest.raises(SystemExit):
        main(["--out", str(tmp_path / "x.png"), "--count", "0"])
    with pytest.raises(SystemExit):
        main(["--out", str(tmp_path / "no" / "such" / "dir.png"), "--count", "1", "--size", "8"])
