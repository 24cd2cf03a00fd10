import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fsistab.bodies import Plate, make_body
from fsistab.errors import InputError
from fsistab.params import Domain, Flow, Solid

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
    assert plate.radius_of_gyration == pytest.approx(0.2891, abs=1e-4)  # docs/model.md §2
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
    """docs/model.md §10: h'' + (2π/U*)² h = 2 C_L/(π m)  <=>  h'' + (Ω/U*_g)² h = C_L/m_g."""
    solid = Solid.cylinder(mass_ratio=20, reduced_velocity=8)
    assert solid.dofs == ("heave",)
    assert solid.freq_ratio / solid.reduced_velocity == pytest.approx(2 * math.pi / 8)
    assert 1 / solid.mass_ratio == pytest.approx(2 / (math.pi * 20))


# --- command settings (fsistab.params: Case, solid_for, *Settings) ------------------------------------


def test_solid_defaults_are_taken_for_none_only():
    from fsistab.params import solid_for

    assert solid_for("plate").mass_ratio == 1000.0 and solid_for("plate").reduced_velocity == 4.7
    cylinder = solid_for("cylinder")  # docs/model.md §10 defaults m = 20, U* = 8, in the generic form
    assert cylinder.mass_ratio == pytest.approx(math.pi * 20 / 2)
    assert cylinder.reduced_velocity == pytest.approx(8 / (2 * math.pi)) and cylinder.dofs == ("heave",)
    for kind in ("plate", "cylinder"):
        with pytest.raises(InputError, match="mass ratio must be positive"):
            solid_for(kind, mass_ratio=0.0)
        with pytest.raises(InputError, match="reduced velocity must be positive"):
            solid_for(kind, reduced_velocity=0.0)
    # the cylinder ignores Ω, ζ_θ and r_θ, which are refused all the same when they make no sense
    for name, value in (("freq_ratio", 0.0), ("zeta_theta", -0.1), ("r_theta", -1.0), ("zeta_h", math.nan)):
        with pytest.raises(InputError):
            solid_for("cylinder", **{name: value})
    with pytest.raises(InputError, match="no pitch"):
        solid_for("cylinder", dofs=("heave", "pitch"))
    with pytest.raises(InputError, match="at most"):
        solid_for("plate", mass_ratio=1e300)


def test_case_checks_every_shape_and_names_its_files():
    from fsistab.params import Case

    case = Case.create("plate", 2900, 5.0, "coarse")
    assert case.tag == "plate_Re2900_a5" and case.kind == "plate"
    with pytest.raises(InputError, match="unknown mesh preset"):
        Case.create("plate", 2900, 0.0, "huge")
    with pytest.raises(InputError, match="chord/thickness"):
        Case.create("cylinder", 40, 0.0, "coarse", aspect_ratio=0.5)  # refused although unused
    with pytest.raises(InputError, match="at most"):
        Case.create("plate", 1e300)
    with pytest.raises(InputError, match="at least 2 body lengths"):
        Case.create("plate", 100, domain=(1.0, 40.0, 20.0))
    with pytest.raises(InputError, match="implemented for the plate"):
        Case.create("cylinder", 40).require_plate("maps")


def test_dofs_text():
    from fsistab.params import parse_dofs

    assert parse_dofs(None, "plate") == ("heave", "pitch") and parse_dofs(None, "cylinder") == ("heave",)
    assert parse_dofs("none", "plate") == () and parse_dofs(" pitch , heave", "plate") == ("pitch", "heave")
    for bad in ("", ",", "twist", "heave,heave"):
        with pytest.raises(InputError):
            parse_dofs(bad, "plate")


def test_map_settings_seeds_and_template():
    from fsistab.params import MapSettings

    settings = MapSettings(mass_range=(20.0, 1e4), start_mass=1000.0)
    assert settings.seeds == (100.0,) and settings.template_mass == 1000.0  # m/100 = 10 < 20: left out
    assert MapSettings(mass_range=(1.0, 1e4)).seeds == (100.0, 10.0)
    # transfer: the start only sets the template's m, clamped into the range
    assert MapSettings(mass_range=(1.0, 100.0), start_mass=1000.0).template_mass == 100.0
    with pytest.raises(InputError, match="must contain --start-mass-ratio"):
        MapSettings(mass_range=(1.0, 100.0), start_mass=1000.0, method="continuation")
    with pytest.raises(InputError, match="--reduced-blocks"):
        MapSettings(reduced_blocks=2)


def test_map_settings_choose_reduced_models_by_mesh_size():
    """Reduced fluid models on the coarse plate (14 597 unknowns), exact samples on the default
    mesh (416 871), where they were measured faster (docs/performance.md); a choice given wins."""
    from fsistab.params import MapSettings

    assert MapSettings().krylov_blocks(14_597) == 60
    assert MapSettings().krylov_blocks(416_871) == 0
    assert MapSettings(reduced_blocks=0).krylov_blocks(14_597) == 0
    assert MapSettings(reduced_blocks=40).krylov_blocks(416_871) == 40


@given(st.integers(max_value=1) | st.integers(min_value=501))
def test_sweep_points_bounded(points):
    from fsistab.params import SweepSettings

    with pytest.raises(InputError, match="--points"):
        SweepSettings(points=points)


@given(st.sampled_from([math.nan, math.inf, -math.inf, 0.0, -1.0]), st.booleans())
def test_intervals_are_finite_and_positive(value, first):
    from fsistab.params import MapSettings, SweepSettings, TransferSettings

    pair = (value, 10.0) if first else (1.0, value)
    for make in (
        lambda: SweepSettings(velocity_range=pair),
        lambda: MapSettings(mass_range=pair),
        lambda: TransferSettings(k_range=pair),
    ):
        with pytest.raises(InputError, match="0 < low < high"):
            make()


def test_theodorsen_settings_refuse_degenerate_slopes():
    from fsistab.params import TheodorsenSettings

    assert (
        TheodorsenSettings(slopes="given", lift_slope_alpha=5.98, moment_slope_alpha=1.562).lift_slope_alpha
        == 5.98
    )
    for lift, moment in ((0.0, 0.0), (0.0, 1.562), (-1.0, 1.562)):
        with pytest.raises(InputError, match="degenerate"):
            TheodorsenSettings(slopes="given", lift_slope_alpha=lift, moment_slope_alpha=moment)
    with pytest.raises(InputError, match="aerodynamic centre at mid-chord"):
        TheodorsenSettings(slopes="given", lift_slope_alpha=5.98, moment_slope_alpha=0.0)
    with pytest.raises(InputError, match="needs both"):
        TheodorsenSettings(slopes="given", lift_slope_alpha=5.98)
    with pytest.raises(InputError, match="need --slopes given"):
        TheodorsenSettings(lift_slope_alpha=5.98)
