"""Dilution of precision of difference-of-arrival geometry (004 §4, after Bard & Ham).

H stacks, per epoch, the rows d(path difference)/d(transmitter position) of the receiver pairs in view;
DOP = sqrt(trace(pinv(H' H))). With one pair H' H has rank one and the pseudo-inverse (SVD) gives
1 / |row|^2, so DOP = 1 / |u_2 - u_1| with u_i the unit vector from receiver i to the transmitter: the
metres of transmitter position per metre of path-difference error along the best-observed direction.
"""

import numpy as np


def tdoa_dop(first, transmitter, second) -> np.ndarray:
    """Positions (m, 3) of the first receiver, the transmitter and the second receiver -> DOP (m,)."""
    u1 = transmitter - first
    u2 = transmitter - second
    rows = u2 / np.linalg.norm(u2, axis=1)[:, None] - u1 / np.linalg.norm(u1, axis=1)[:, None]
    out = np.empty(len(rows))
    for k, row in enumerate(rows):
        H = row[None, :]
        out[k] = np.sqrt(np.trace(np.linalg.pinv(H.T @ H)))
    return out
