"""The filter state as a list of blocks, each with its own transition rule.

- spacecraft (6): x, y, z, vx, vy, vz; transition = the dynamics model's STM over the step;
- clock (2 or 3): phase, frequency (, aging) in range units; transition Phi_ij = dt^(j-i) / (j-i)!;
- constant (1 or 3): a range bias, a manoeuvre's Delta-v (3) or any other constant parameter; identity
  transition. A Delta-v block acts once, at its burn epoch: filter_loop.apply_burns adds it to its
  spacecraft's velocity (state and covariance, x <- J x, P <- J P J^T).
Process noise is a fixed (n, n) block-diagonal Q built block by block by the problem setup. Consider
blocks (zero gain, Schmidt-Kalman) come last, so the estimated states are a prefix of the state.
"""

from dataclasses import dataclass

import numpy as np

BLOCK_SPACECRAFT = 0
BLOCK_CLOCK = 1
BLOCK_CONSTANT = 2
BLOCK_SIZES = {BLOCK_SPACECRAFT: (6,), BLOCK_CLOCK: (2, 3), BLOCK_CONSTANT: (1, 3)}


@dataclass(frozen=True)
class StateBlock:
    kind: int
    size: int
    owner: str  # the participant or link the block belongs to
    consider: bool = False

    def __post_init__(self):
        if self.size not in BLOCK_SIZES[self.kind]:
            raise ValueError(f"block kind {self.kind} cannot have size {self.size}")


@dataclass(frozen=True, eq=False)
class StateLayout:
    blocks: tuple[StateBlock, ...]

    def __post_init__(self):
        considered = [b.consider for b in self.blocks]
        if any(considered) and considered != sorted(considered):
            raise ValueError("consider blocks must come after every estimated block")

    @property
    def starts(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum([b.size for b in self.blocks])[:-1]]).astype(np.int64)

    @property
    def n(self) -> int:
        return int(sum(b.size for b in self.blocks))

    def arrays(self):
        """(kind (B,), start (B,), size (B,)) for the compiled loop."""
        return (np.array([b.kind for b in self.blocks], dtype=np.int64), self.starts,
                np.array([b.size for b in self.blocks], dtype=np.int64))

    @property
    def n_estimated(self) -> int:
        """States before the first consider block (all of them if none)."""
        return int(sum(b.size for b in self.blocks if not b.consider))

    @property
    def has_consider(self) -> bool:
        return any(b.consider for b in self.blocks)

    def start_of(self, kind: int, owner: str) -> int:
        for block, start in zip(self.blocks, self.starts):
            if block.kind == kind and block.owner == owner:
                return int(start)
        return -1

    def spacecraft_owners(self) -> list[str]:
        return [b.owner for b in self.blocks if b.kind == BLOCK_SPACECRAFT]
