"""The block controller law and its two inversions (used by the UKF and the NMPC)."""
import pytest

from drill_core.block_control import block_command, integral_for_command, reference_for_command

LAW = dict(static_stretch_m=1.7, kp=0.8, ki_per_s=0.05)


@pytest.mark.parametrize("command, position, integral", [(3.0, 1.2, -4.0), (-2.5, 0.0, 10.0)])
def test_the_inverted_reference_reproduces_the_command(command, position, integral):
    reference = reference_for_command(command, position, integral, **LAW)
    assert block_command(reference, position, integral, **LAW) == pytest.approx(command, abs=1e-12)


def test_the_inverted_integral_reproduces_the_command():
    integral = integral_for_command(4.0, 2.5, 1.1, **LAW)
    assert block_command(2.5, 1.1, integral, **LAW) == pytest.approx(4.0, abs=1e-12)
    # by hand: 4 = 2.5 + 1.7 + 0.8 (2.5 - 1.1) + 0.05 z  ->  z = -26.4
    assert integral == pytest.approx(-26.4, abs=1e-9)
