"""The counter-based generator of survival runs: Philox4x32-10 and the draws built on it."""
import math

import numpy as np
import pytest

from monkeystudy.kernel.noise import normal_pair, philox4x32, standard_draw, uniform_pair

#: Random123's known-answer vectors for Philox4x32-10 (its kat_vectors file): counter, key,
#: expected output, as unsigned 32-bit words
KAT = [
    ((0, 0, 0, 0), (0, 0), (0x6627E8D5, 0xE169C58D, 0xBC57AC4C, 0x9B00DBD8)),
    ((0xFFFFFFFF,) * 4, (0xFFFFFFFF,) * 2, (0x408F276D, 0x41C83B0E, 0xA20BC7C6, 0x6D5451FD)),
    ((0x243F6A88, 0x85A308D3, 0x13198A2E, 0x03707344), (0xA4093822, 0x299F31D0),
     (0xD16CFE09, 0x94FDCCEB, 0x5001E420, 0x24126EA1)),
]


@pytest.mark.parametrize("counter, key, want", KAT)
def test_philox_matches_the_known_answers(counter, key, want):
    assert philox4x32(*counter, *key) == want              # compiled
    assert philox4x32.py_func(*counter, *key) == want      # and as plain Python


def test_a_draw_depends_on_every_part_of_its_key_and_on_nothing_else():
    base = uniform_pair(7, 3, 11, 2)
    assert uniform_pair(7, 3, 11, 2) == base
    for other in ((8, 3, 11, 2), (7, 4, 11, 2), (7, 3, 12, 2), (7, 3, 11, 3),
                  (7 + (1 << 32), 3, 11, 2)):            # the seed's high word is key too
        assert uniform_pair(*other) != base


def test_uniform_and_normal_draws_have_their_moments():
    n = 100_000
    u = np.array([uniform_pair(1, r, 0, 0) for r in range(n)]).ravel()
    assert u.min() >= 0.0 and u.max() < 1.0
    assert abs(u.mean() - 0.5) < 5 * math.sqrt(1 / 12 / u.size)
    z = np.array([normal_pair(1, r, 0, 0) for r in range(n)]).ravel()
    assert abs(z.mean()) < 5 / math.sqrt(z.size)
    assert abs(z.std() - 1.0) < 5 * math.sqrt(0.5 / z.size)
    # the tails are Gaussian: P(|z| > 3) = 0.0027
    tail = np.mean(np.abs(z) > 3.0)
    assert abs(tail - 0.0027) < 5 * math.sqrt(0.0027 / z.size)
    w = np.array([standard_draw(1, r, 0, 0, True) for r in range(n)])
    assert w.min() >= -1.0 and w.max() < 1.0 and abs(w.mean()) < 5 * math.sqrt(1 / 3 / n)
