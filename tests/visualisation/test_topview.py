import numpy as np
import pytest
from matplotlib.figure import Figure

from grace.domain.assembly import Assembly, Part, PartType, planar_pose
from grace.domain.orders import GroundTruth
from grace.domain.sample import LabelledAssembly
from grace.visualisation.topview import draw, title, topview_png


def _sample(feasible: bool) -> LabelledAssembly:
    parts = (
        Part("bar", PartType.PROFILE_300, planar_pose(0, 0, 1)),
        Part("stem", PartType.PROFILE_200, planar_pose(0, 120)),
        Part("br", PartType.BRACKET, planar_pose(20, 20)),
    )
    truth = GroundTruth.explore(3, lambda state, part: feasible or part != 2)
    cause = None if feasible else "collision"
    return LabelledAssembly(Assembly(parts, name="A3-000007"), truth, {"cause": cause})


def test_titles_say_feasibility():
    assert title(_sample(True)) == "A3-000007: feasible, 6 orders"
    assert title(_sample(False)) == "A3-000007: infeasible (collision)"
    unnamed = _sample(True)
    unnamed.assembly.name = "frame"
    assert title(unnamed).startswith("A3 frame: ")


def test_draw_labels_every_part_and_surface():
    ax = Figure().subplots()
    draw(ax, _sample(True))
    texts = [t.get_text() for t in ax.texts]
    assert sorted(texts[i] for i in (0, 5, 10)) == ["0", "1", "2"]  # part number, then its surfaces
    assert (
        texts.count("1") == 1 + 3 and texts.count("4") == 2
    )  # surface 1 on every part, 4 on profiles
    assert len(ax.patches) == 4  # two profiles and the bracket's two legs
    x0, x1 = ax.get_xlim()
    assert x0 < -150 and x1 > 150


def test_png_grid():
    png = topview_png([_sample(True), _sample(False)])
    assert png.startswith(b"\x89PNG\r\n\x1a\n") and len(png) > 10_000
    with pytest.raises(ValueError):
        topview_png([])
    assert np.frombuffer(png[16:24], dtype=">u4").tolist()[0] > 0  # IHDR width


def test_mechanisms_name_the_infeasibility_and_clamps_are_drawn():
    sample = _sample(False)
    sample.info.update(mechanisms=["narrow_rails", "clamp"], clamps=[[-20, -60, 20, -20], [], []])
    assert title(sample) == "A3-000007: infeasible (narrow_rails, clamp)"
    ax = Figure().subplots()
    draw(ax, sample)
    assert len(ax.patches) == 5  # the parts' four boxes and one clamp
