import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fsistab.errors import InputError
from fsistab.params import Domain, Flow, Plate, Solid, make_body

bad_numbers = st.one_of(
    st.floats(max_value=0.0, allow_nan=False), st.just(math.nan), st.just(math.inf), st.just(-math.inf)
)


@given(bad_numbers)
def test_reynolds_must_be_positive_and_finite(value):
    with pytest.raises(InputError, match="Reynolds"):
        Flow(value)


@given(bad_numbers)
def test_solid_parameters_refused(value):
    with pytest.raises(InputError, match="mass ratio"):
        Solid(mass_ratio=value)
    with pytest.raises(InputError, match="reduced velocity"):
        Solid(reduced_velocity=value)


@given(st.floats(max_value=1.0, allow_nan=False))
def test_plate_aspect_ratio_above_one(value):
    with pytest.raises(InputError, match="chord/thickness"):
        Plate(aspect_ratio=value)


def test_defaults_and_conventions():
    plate = Plate()
    assert plate.thickness == pytest.approx(0.05)
    assert plate.radius_of_gyration == pytest.approx(0.2891, abs=1e-4)  # MODEL.md §2
    assert Flow(100, 5).theta0 == pytest.approx(-math.radians(5))  # θ0 = -α0
    assert Solid(dofs=("pitch", "heave")).dofs == ("heave", "pitch")
    with pytest.raises(InputError):
        Solid(dofs=("twist",))
    with pytest.raises(InputError):
        Solid(zeta_theta=-0.1)
    with pytest.raises(InputError, match="unknown body"):
        make_body("sphere")
    with pytest.raises(InputError):
        Domain(1.0, 40, 20)


def test_cylinder_scalings_map_to_generic_form():
    """MODEL.md §10: h'' + (2π/U*)² h = 2 C_L/(π m)  <=>  h'' + (Ω/U*_g)² h = C_L/m_g."""
    solid = Solid.cylinder(mass_ratio=20, reduced_velocity=8)
    assert solid.dofs == ("heave",)
    assert solid.freq_ratio / solid.reduced_velocity == pytest.approx(2 * math.pi / 8)
    assert 1 / solid.mass_ratio == pytest.approx(2 / (math.pi * 20))
