"""Object specifications: library defaults, overrides and validation."""

from __future__ import annotations

import math

import mujoco
import pytest

from sim.hand.model import build_model
from sim.hand.objects import LIBRARY, ObjectSpec, ObjectSpecError, as_object_spec, make_object


def test_library_matches_calibration_facts() -> None:
    can = make_object("can")
    assert can.mass_kg == pytest.approx(0.386)
    assert can.width_m == pytest.approx(0.066)
    assert can.height_m == pytest.approx(0.122)
    assert make_object("block").mass_kg == pytest.approx(0.461)
    assert make_object("ball").width_m == pytest.approx(0.070)
    egg = make_object("egg")
    assert 0.4 <= egg.break_force_n <= 11.5  # Virtual Eggs Test range
    assert make_object("cup").break_force_n < 10
    assert not make_object("can").breakable


def test_block_density_is_aluminium() -> None:
    block = make_object("block")
    volume_m3 = 8 * math.prod(block.size_m)
    assert block.mass_kg / volume_m3 == pytest.approx(2700, rel=0.02)


def test_overrides_replace_only_named_fields() -> None:
    obj = make_object("can", mass_kg=0.4, friction=0.5)
    assert (obj.mass_kg, obj.friction) == (0.4, 0.5)
    assert obj.size_m == LIBRARY["can"].size_m
    assert as_object_spec({"name": "egg", "friction": 1.2}).friction == 1.2
    assert as_object_spec("ball") == LIBRARY["ball"]


@pytest.mark.parametrize("kwargs, field", [
    ({"mass_kg": -0.1}, "mass_kg"),
    ({"mass_kg": 2.5}, "mass_kg"),
    ({"friction": 0.1}, "friction"),
    ({"friction": 1.6}, "friction"),
    ({"break_force_n": 0.0}, "break_force_n"),
    ({"solref": (0.0001, 1.0)}, "solref"),
    ({"solimp": (0.9, 0.5, 0.001)}, "solimp"),
])
def test_invalid_parameters_name_field_value_and_range(kwargs: dict, field: str) -> None:
    with pytest.raises(ObjectSpecError) as err:
        make_object("can", **kwargs)
    message = str(err.value)
    assert message.startswith(field)
    value = next(iter(kwargs.values()))
    assert repr(value) in message or str(value) in message
    assert "\n" not in message
    assert isinstance(err.value, ValueError)


def test_unknown_shape_name_field_and_size() -> None:
    with pytest.raises(ObjectSpecError, match="shape: expected one of"):
        ObjectSpec("x", "cone", (0.03,), 0.1)
    with pytest.raises(ObjectSpecError, match="object name: expected one of"):
        make_object("teapot")
    with pytest.raises(ObjectSpecError, match="unknown \\['mass'\\]"):
        make_object("can", mass=0.3)
    with pytest.raises(ObjectSpecError, match="size_m: a box needs 3"):
        ObjectSpec("x", "box", (0.03, 0.03), 0.1)
    with pytest.raises(ObjectSpecError, match="width_m"):
        ObjectSpec("x", "sphere", (0.2,), 0.1)


@pytest.mark.parametrize("name", sorted(LIBRARY))
def test_model_carries_object_parameters(name: str) -> None:
    obj = make_object(name)
    model = build_model(obj)
    geom = model.geom("object")
    assert model.body("object").mass[0] == pytest.approx(obj.mass_kg)
    assert geom.friction[0] == pytest.approx(obj.friction)
    assert tuple(geom.solref) == pytest.approx(obj.solref)
    assert tuple(geom.solimp[:3]) == pytest.approx(obj.solimp)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    # Rests on the table (z = 0) without initial penetration into it.
    assert data.xpos[model.body("object").id][2] == pytest.approx(obj.half_height_m)
