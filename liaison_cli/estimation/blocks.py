"""The filter state as a list of blocks, each with its own transition rule.

- spacecraft (6): x, y, z, vx, vy, vz; transition = the dynamics model's STM over the step;
- clock (2 or 3): phase, frequency (, aging) in range units; transition Phi_ij = dt^(j-i) / (j-i)!;
- constant (1 or 3): a range bias, a manoeuvre's Delta-v (3) or any other constant parameter; identity
  transition. A Delta-v block acts once, at its burn epoch: filter_loop.apply_burns adds it to its
  spacecraft's velocity (state and covariance, x <- J x, P <- J P J^T).
- parameter (1): a dynamics model's parameter (dynamics.registry.DynamicsParameter, e.g. C_R) of one
  spacecraft (owner 'cr L1A') or of every spacecraft (owner 'cr formation': the dated model has one C_R A/m
  for all); constant, but it moves its spacecraft: the transition couples them by the column
  gamma = d x_spacecraft / d parameter (dynamics.model.propagate_parameter_into), so Phi is block-diagonal
  plus those columns (ekf.predict_covariance_into). It has no process noise.
- empirical (3): a spacecraft's first-order Gauss-Markov acceleration (owner 'accel L1A'; dynamic model
  compensation, estimation.process_noise): transition exp(-dt / tau) on itself and kinematic gains into its
  spacecraft's position and velocity (filter_loop.time_update), process noise coupled with the spacecraft's.
Process noise is a fixed (n, n) Q built block by block by the problem setup (block-diagonal but for the
empirical accelerations' coupling to their spacecraft; a RIC density adds its spacecraft block at each step,
estimation.ric_noise). Consider
blocks (zero gain, Schmidt-Kalman) come last, so the estimated states are a prefix of the state; the
empirical accelerations come last among the estimated blocks, so the states the NEES covers (n_nees) are a
prefix too.
"""

from dataclasses import dataclass

import numpy as np

BLOCK_SPACECRAFT = 0
BLOCK_CLOCK = 1
BLOCK_CONSTANT = 2
BLOCK_PARAMETER = 3
BLOCK_EMPIRICAL = 4
BLOCK_SIZES = {BLOCK_SPACECRAFT: (6,), BLOCK_CLOCK: (2, 3), BLOCK_CONSTANT: (1, 3), BLOCK_PARAMETER: (1,),
               BLOCK_EMPIRICAL: (3,)}
# The owner names of blocks that belong to something other than a participant: f"{ROLE} {name}".
ROLE_MANOEUVRE = "dv"
ROLE_LINK_BIAS = "bias"
ROLE_EMPIRICAL = "accel"  # a spacecraft's empirical (Gauss-Markov) acceleration
FORMATION = "formation"  # a parameter block shared by every spacecraft block


def owner_name(role: str, name) -> str:
    """The owner of a role's block: 'dv L1A' (a manoeuvre's Delta-v), 'bias 0' (link 0's range bias), 'cr L1A'
    or 'cr formation' (a dynamics parameter of one spacecraft or of all)."""
    return f"{role} {name}"


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
        estimated = [b.kind == BLOCK_EMPIRICAL for b in self.blocks if not b.consider]
        if estimated != sorted(estimated):
            raise ValueError("empirical-acceleration blocks must come after every other estimated block")

    @property
    def starts(self) -> np.ndarray:
        return np.concatenate([[0], np.cumsum([b.size for b in self.blocks])[:-1]]).astype(np.int64)

    @property
    def n(self) -> int:
        return int(sum(b.size for b in self.blocks))

    def arrays(self):
        """(kind (B,), start (B,), size (B,), parameter (B,)) for the compiled loop: parameter is, for a
        spacecraft block, the start of its dynamics-parameter block (-1: none), for an empirical-acceleration
        block the start of the spacecraft block it accelerates, and -1 for every other block."""
        starts = self.starts
        parameter = np.full(len(self.blocks), -1, dtype=np.int64)
        for b, block in enumerate(self.blocks):
            if block.kind == BLOCK_EMPIRICAL:
                parameter[b] = self.start_of(BLOCK_SPACECRAFT, block.owner.split(" ", 1)[1])
            elif block.kind == BLOCK_PARAMETER:
                owner = block.owner.split(" ", 1)[1]
                parameter[[i for i, o in enumerate(self.blocks)
                           if o.kind == BLOCK_SPACECRAFT and owner in (o.owner, FORMATION)]] = starts[b]
        return (np.array([b.kind for b in self.blocks], dtype=np.int64), starts,
                np.array([b.size for b in self.blocks], dtype=np.int64), parameter)

    @property
    def n_estimated(self) -> int:
        """States before the first consider block (all of them if none)."""
        return int(sum(b.size for b in self.blocks if not b.consider))

    @property
    def n_nees(self) -> int:
        """The states the NEES covers: the estimated ones with a truth of their own, before the empirical
        accelerations (whose truth is whatever force the model lacks, unknown in general: model_error's
        acceleration when a study states one, and the settled columns compare against that)."""
        return int(sum(b.size for b in self.blocks if not b.consider and b.kind != BLOCK_EMPIRICAL))

    @property
    def has_consider(self) -> bool:
        return any(b.consider for b in self.blocks)

    def start_of(self, kind: int, owner: str) -> int:
        for block, start in zip(self.blocks, self.starts):
            if block.kind == kind and block.owner == owner:
                return int(start)
        return -1

    def empirical_couplings(self) -> list[tuple[int, int]]:
        """(spacecraft block start, its empirical-acceleration block start) per empirical block."""
        return [(self.start_of(BLOCK_SPACECRAFT, b.owner.split(" ", 1)[1]), int(a))
                for b, a in zip(self.blocks, self.starts) if b.kind == BLOCK_EMPIRICAL]

    def spacecraft_owners(self) -> list[str]:
        return [b.owner for b in self.blocks if b.kind == BLOCK_SPACECRAFT]
