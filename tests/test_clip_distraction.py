"""benchmarks/clip_distraction.py: each clip alone as the background, its return beside its statistics."""
import csv
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))

from clip_distraction import main  # noqa: E402

from dcs_torchrl.pretrained import load_pretrained  # noqa: E402
from videos.files import write_frames  # noqa: E402


@pytest.mark.slow  # the benchmark script's own run (an evaluation per clip and one alone)
def test_each_clip_alone_and_a_rerun_skips_what_it_holds(tmp_path, capsys):
    videos = tmp_path / "videos"
    write_frames(videos / "a_red", 3, rgb=(220, 30, 20))
    write_frames(videos / "b_blue", 3, rgb=(20, 40, 220))
    out = tmp_path / "clips.csv"
    main(["sac_rad_cartpole_swingup", "--videos", str(videos), "--beta", "1", "--episodes", "1", "--out", str(out)])
    rows = list(csv.DictReader(out.open()))
    assert [r["clip"] for r in rows] == ["a_red", "b_blue"]
    assert float(rows[0]["warmth"]) > 0.1 > -0.1 > float(rows[1]["warmth"])  # red: R - B high; blue: low
    printed = capsys.readouterr().out
    assert "correlation of each statistic" in printed
    assert "n/a (2 clips, spread" in printed  # two clips: no correlation computed (it would be +-1 or nan)
    # the second clip's return is that of an evaluation with that clip alone as the background
    write_frames(tmp_path / "only_blue" / "b_blue", 3, rgb=(20, 40, 220))
    alone = load_pretrained("sac_rad_cartpole_swingup").evaluate(
        1, background_blend=1.0, num_videos=1, dynamic=False, background_dir=str(tmp_path / "only_blue"))
    assert float(rows[1]["mean_return"]) == alone.mean
    main(["sac_rad_cartpole_swingup", "--videos", str(videos), "--beta", "1", "--episodes", "1", "--out", str(out)])
    assert len(list(csv.DictReader(out.open()))) == 2  # nothing evaluated again, nothing appended
    with pytest.raises(SystemExit, match="holds rows measured with .*'beta': '1'.*choose another --out"):
        main(["sac_rad_cartpole_swingup", "--videos", str(videos), "--beta", "0.5", "--episodes", "1", "--out", str(out)])
    assert len(list(csv.DictReader(out.open()))) == 2
