"""The 3-D joint construction against the paper's closed forms (eqs. 1-4) and itself."""

import numpy as np
import pytest
from cardan_forces.driveline.kinematics import kinematics, rest_geometry
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.conftest import variant


def _scene(g1, g2, arrangement="Z", phase2=0.0):
    return variant(
        arrangement=arrangement,
        joints=[
            {"name": "uj1", "articulation_deg": g1, "hs_m": 0.03, "rs_m": 0.005, "rb_m": 0.005,
             "ht_m": 0.02, "hb_m": 0.02, "rt_m": 0.006},
            {"name": "uj2", "articulation_deg": g2, "yoke_phase_deg": phase2, "hs_m": 0.03,
             "rs_m": 0.005, "rb_m": 0.005, "ht_m": 0.02, "hb_m": 0.02, "rt_m": 0.006},
        ],
    )


Q = np.linspace(-7.0, 7.0, 401)


@settings(max_examples=25, deadline=None, derandomize=True)
@given(g1=st.floats(0.0, 85.0), g2=st.floats(0.0, 85.0), arrangement=st.sampled_from("ZW"))
def test_closed_forms_eqs_1_to_4(g1, g2, arrangement):
    kin = kinematics(rest_geometry(_scene(g1, g2, arrangement)), Q)
    c1, c2 = np.cos(np.radians(g1)), np.cos(np.radians(g2))
    # eq (1)/(2): tan phi_j = tan phi_i / cos g1, compared as sin/cos to avoid the poles
    phi_i, phi_j, phi_k = kin.phi
    assert np.allclose(np.sin(phi_j) * c1 * np.cos(phi_i), np.sin(phi_i) * np.cos(phi_j),
                       atol=1e-12)
    # eq (3): dphi_j/dphi_i = cos g1 / (1 - cos^2 phi_i sin^2 g1)
    s1 = np.sin(np.radians(g1))
    expected = c1 / (1.0 - np.cos(phi_i) ** 2 * s1**2)
    assert np.allclose(kin.ratio[1], expected, rtol=1e-10)
    # eq (4): tan phi_k = tan phi_i cos g2 / cos g1 (yokes on the intermediate shaft in phase)
    assert np.allclose(np.sin(phi_k) * c1 * np.cos(phi_i), np.sin(phi_i) * c2 * np.cos(phi_k),
                       atol=1e-12)
    # angles stay continuous and monotone
    assert np.all(np.diff(kin.phi, axis=1) > 0)


def test_equal_angles_give_uniform_output_in_z_and_w():
    for arrangement in "ZW":
        kin = kinematics(rest_geometry(_scene(30.0, 30.0, arrangement)), Q)
        assert np.allclose(kin.ratio[2], 1.0, atol=1e-12)
        assert np.allclose(kin.phi[2], Q, atol=1e-12)
    # out of phase yokes on the intermediate shaft do not cancel
    kin = kinematics(rest_geometry(_scene(30.0, 30.0, "Z", phase2=90.0)), Q)
    assert np.ptp(kin.ratio[2]) > 0.5


def test_frames_are_orthonormal_and_perpendicular_to_their_shafts(paper):
    geo = rest_geometry(paper)
    kin = kinematics(geo, Q)
    for j in range(2):
        e1, e2, e3 = kin.e1[j], kin.e2[j], kin.e3[j]
        assert np.allclose(np.einsum("ti,ti->t", e1, e2), 0, atol=1e-13)
        assert np.allclose(e1 @ geo.axes[j], 0, atol=1e-13)
        assert np.allclose(e2 @ geo.axes[j + 1], 0, atol=1e-13)
        assert np.allclose(np.linalg.norm(e3, axis=1), 1, atol=1e-13)


@pytest.mark.parametrize("g1,g2,arrangement", [(30, 30, "Z"), (10, 45, "W"), (0, 70, "Z")])
def test_derivatives_match_finite_differences(g1, g2, arrangement):
    geo = rest_geometry(_scene(g1, g2, arrangement, phase2=20.0))
    q, h = np.linspace(0.1, 6.0, 37), 1e-5
    kin, up, down = kinematics(geo, q), kinematics(geo, q + h), kinematics(geo, q - h)
    assert np.allclose(kin.ratio, (up.phi - down.phi) / (2 * h), atol=1e-8)
    assert np.allclose(kin.ratio_dq, (up.ratio - down.ratio) / (2 * h), atol=1e-6)
    assert np.allclose(kin.pin_rate_dq, (up.pin_rate - down.pin_rate) / (2 * h), atol=1e-6)
    # the cross-pin's angular velocity rotates its frame: de/dq = w x e
    for e_now, e_up, e_down in ((kin.e1, up.e1, down.e1), (kin.e2, up.e2, down.e2)):
        assert np.allclose((e_up - e_down) / (2 * h), np.cross(kin.pin_rate, e_now), atol=1e-8)
