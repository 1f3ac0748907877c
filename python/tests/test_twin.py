"""orbcal.twin on real images: twin.json's content as a dict, naming what the clean twins of six views of the
industrial_calibration ChArUco set miss (read from ../shared/data beside the checkout; skipped, with the
reason, where they are absent)."""
import json
import pathlib

import pytest

import orbcal

SOURCE_DIR = pathlib.Path(__file__).resolve().parents[2]
DATA = SOURCE_DIR.parent / "shared" / "data" / "ic-charuco"


@pytest.fixture(scope="module")
def six_views(tmp_path_factory):
    if not (DATA / "images" / "0.png").exists():
        pytest.skip(f"{DATA} is absent: the real ChArUco images are not in this checkout's surroundings")
    folder = tmp_path_factory.mktemp("ic6")
    rows = ["image,pose"] + [f"{DATA}/images/{k}.png,{DATA}/poses/{k}.yaml" for k in (0, 3, 6, 8, 12, 15)]
    (folder / "six.csv").write_text("\n".join(rows) + "\n")
    text = (SOURCE_DIR / "examples" / "real-images" / "ic-charuco.yaml").read_text()
    (folder / "six.yaml").write_text(text.replace("files: [ic-charuco.csv]", "files: [six.csv]"))
    return folder / "six.yaml"


def test_twin_returns_twin_json_and_names_what_the_clean_twins_miss(six_views, tmp_path):
    out = tmp_path / "twin"
    t = orbcal.twin(str(six_views), str(out))
    # the dict is twin.json's content
    assert t == json.loads((out / "twin.json").read_text())
    assert t["views"] == 6 and t["profiled"] is False
    scatter = t["statistics"]["corner_scatter_px"]
    assert scatter["real"]["value"] > 5 * scatter["rendered"]["value"], scatter
    # the set's camera: black about 33 DN, white about 234 DN, edges 3 px wide; a clean render: 10, 172, 1.1 px
    named = {e["name"]: e for e in t["effects"]}
    assert named["black level"]["size"] > 10 and named["white level"]["size"] > 40, named
    assert named["blur"]["size"] > 0.5, named
    # its intrinsics have no distortion coefficients: the corners show more radial distortion than the twins'
    # (on six views not significantly: all 16 name it, docs/twins.md)
    lens = t["statistics"]["lens_shift_px"]
    assert lens["real"]["value"] > lens["rendered"]["value"] + 1.0, lens
    assert (out / "camera_profile.yaml").exists()


def test_twin_refuses_a_description_without_images(tmp_path):
    with pytest.raises(orbcal.Error, match="images"):
        orbcal.twin(str(SOURCE_DIR / "scenes" / "iiwa7_0kg.yaml"), str(tmp_path / "t"))
