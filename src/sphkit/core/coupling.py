"""The boundary coupling: the one typed object through which every pressure solver meets the
boundary (DESIGN.md, "one boundary coupling"; the roles it combines are the Protocols of
:mod:`sphkit.core.methods`).

:class:`BoundaryCoupling` holds the mirror weights of the boundary pressure, the boundary
pressure a :class:`~sphkit.core.methods.BoundaryPressure` model extrapolates
(:class:`BoundaryKappa`), and the response of boundaries that yield to the pressure
(:class:`~sphkit.core.methods.MovingBoundary`: dynamic rigid bodies, strong coupling). Its
defaults do nothing: mirrored pressure, static walls.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from sphkit.backend import device_of
from sphkit.core import arrays
from sphkit.core.methods import BoundaryModel, BoundaryPressure, MovingBoundary

if TYPE_CHECKING:
    from sphkit.core.neighbors import NeighborList
    from sphkit.core.state import SimState


#: ``solved: "density"`` (and its rows of ``"stratified"``): a wall particle holds its start
#: value only where every fluid neighbour had a filled kernel then, ``rho / rho0 >= 1 -
#: COVERED_TOLERANCE``
#: (:meth:`BoundaryCoupling.wall_rest`). The start-up's masses make filled kernels exact to
#: 1e-6 (:data:`sphkit.world.startup.MASS_TOLERANCE`); a free surface's top row lacks 10-20 %.
COVERED_TOLERANCE = 1e-3


class BoundaryCoupling:
    """How every pressure solver meets the boundary, the same way for all of them.

    * **mirror weights** (:meth:`mirror`): the boundary field ``pressure_mirror`` ``m_b``, the
      share of mirrored boundary pressure in the boundary term
      ``-sum_b V_b ((1 + m_b) k_i + k_b) grad W_ib`` (:func:`sphkit.core.ppe.
      kappa_accel_cached`; 0 where a boundary model does not set it);
    * **boundary pressure** (:meth:`boundary_kappa`, :meth:`prepare`, :meth:`correct_mirrored`):
      the extrapolated ``k_b = p_b / rho0`` of a :class:`BoundaryPressure` model, or nothing
      (mirrored pressure, the default);
    * **moving boundaries** (:meth:`predict`, :meth:`response`, :meth:`take_impulse`,
      :meth:`displacement`): how boundary particles of bodies that yield to the pressure move
      inside the solves (strong coupling, Gissler et al. 2019); static walls by default;
    * **the boundary at predicted positions** (:meth:`boundary_at`): the boundary model's
      neighbours for fluid positions inside a solve (maps' virtual particles).
    """

    def __init__(self, pressure: BoundaryPressure | None = None,
                 moving: MovingBoundary | None = None,
                 model: BoundaryModel | None = None, symmetric: bool = False,
                 solved: bool | str = False) -> None:
        """``solved``: the scene's ``configuration.boundary.solved`` (False; True or
        ``"velocity"``; ``"density"`` and ``"stratified"``: see :meth:`solved_walls` and
        :meth:`wall_rest`)."""
        self.pressure = pressure
        #: the symmetric boundary term ``V_b k_i`` in the PPE solvers (see :meth:`mirror`)
        self.symmetric = symmetric
        #: the static walls' pressures are unknowns of the PPE (:meth:`solved_walls`)
        self.solved = bool(solved)
        #: ``solved: "density"`` or ``"stratified"``: the density solves hold the fluid's
        #: density at each solved wall particle at its rest value (:meth:`wall_rest`), not only
        #: its rate
        self.density_walls = solved in ("density", "stratified")
        #: ``solved: "stratified"``: only the wall particles beside a lighter fluid below a
        #: heavier one are solved, the others take the boundary pressure model's value
        #: (:meth:`solved_walls`)
        self.stratified = solved == "stratified"
        self._rows: tuple[int, int, np.ndarray] | None = None  # the step's stratified rows
        self.moving = moving
        self.model = model
        self._still = np.zeros((0, 0))
        self._no_body: np.ndarray | None = None  # the body numbers of a boundary without bodies
        self._kb: np.ndarray | None = None  # the model's k_b, kept from solve to solve

    def boundary_at(self, state: SimState, dx: np.ndarray, motion: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, NeighborList, np.ndarray]:
        """The boundary neighbours ``(x_b, V_b, lists, body)`` of a solve's predicted fluid
        positions ``x + dx`` (PCISPH's prediction, PBF's sweeps): the boundary model's
        :meth:`BoundaryModel.boundary_at` where it places them anew (density maps); else the
        step's moved along with the fluid, :meth:`BoundaryModel.following` (volume maps' virtual
        particles slide along the wall); else the step's own (boundary particles). ``body``:
        the boundary field ``rigid_body`` of the step's, zeros where a state has none.
        ``motion`` (:meth:`motion`; None: the step-start poses): the bodies at their predicted
        poses, the maps queried there, the step's or sliding particles moved with them
        (:meth:`MovingBoundary.displaced`)."""
        at = self.model.boundary_at(state, dx, motion) if self.model is not None else None
        if at is not None:
            return at
        b = state.boundary
        moved = self.model.following(state, dx) if self.model is not None else None
        bx, bV, lists = moved if moved is not None else (b["x"], b["V"], state.nl_fb)
        if "rigid_body" in b.specs and b["rigid_body"].shape[0] == b.n:
            body = b["rigid_body"]
        else:  # no bodies: one array of zeros, kept across the solvers' sweeps
            if self._no_body is None or self._no_body.shape[0] != b.n \
                    or device_of(self._no_body) != device_of(b["x"]):
                self._no_body = arrays.zeros(b.n, np.int64, like=b["x"])
            body = self._no_body
        if motion is not None:
            bx = self.moving.displaced(motion, bx, body)
        return bx, bV, lists, body

    @property
    def reacts(self) -> bool:
        """Whether moving bodies take the fluid's reaction (:meth:`pair_reaction`)."""
        return self.moving is not None and self.moving.reacts

    def pair_reaction(self, state: SimState, k: np.ndarray, x: np.ndarray, bx: np.ndarray,
                      bV: np.ndarray, lists: NeighborList, body: np.ndarray
                      ) -> np.ndarray | None:
        """The bodies' reaction (bodies, 6) to the boundary share ``-k_i V_b grad W(x_i -
        x_b)`` (:meth:`MovingBoundary.pair_reaction`); None without moving bodies."""
        if self.moving is None:
            return None
        return self.moving.pair_reaction(state, k, x, bx, bV, lists, body)

    # -- boundary pressure ----------------------------------------------------------------------
    def mirror(self, state: SimState, diagonal: bool = False) -> np.ndarray:
        """The mirror weights ``m_b`` (N_boundary,); ``diagonal``: the weights the Jacobi
        diagonals use, which count extrapolated boundary pressures as mirrored.

        ``symmetric`` (scene ``configuration.boundary.symmetric``): ``m_b = 0`` and no
        extrapolated ``k_b`` (:meth:`boundary_kappa`), SPlisHSPlasH's boundary term ``V_b k_i``.
        Only that term keeps the PPE operator symmetric positive (semi)definite in p (the
        divergence of the boundary pairs has the same ``V_b grad W_ib`` once); with full
        mirroring or the MLS value the wall pushes a particle harder than the divergence
        accounts for, which a single fluid tolerates but which turns the smallest eigenvalue
        negative once a light phase lies between walls and a heavy one (measured, 2D column
        1000 over 100 kg/m^3, r = 2 cm: eigenvalues of the diagonal-scaled operator from
        -0.0025 (MLS) / -0.0018 (mirror) to +0.0077 (this), the mode being the light layer's
        pressure; Jacobi then diverges along it and DFSPH, IISPH blew up at 1.1-1.6 s;
        validation/README.md, "Several fluids"). Not the default: on lattice walls it lets a
        resting light-over-heavy column move at 0.3 m/s and steepens the hydrostatic slopes
        by 5-10 %."""
        b = state.boundary
        if self.symmetric:  # the symmetric term (see below)
            return arrays.zeros(b.n, b.dtype, like=b["x"])
        m = self._mirror_field(state)
        if self.solved:  # the walls' own k_b instead (solved_walls); with "stratified" the
            # model's k_b at the others, whose share the diagonals leave out (with it PCISPH's
            # 1:10 overturn blew up at 1.63 s; validation/README.md, "Solved walls where the
            # fluid is stratified")
            return np.where(self.solved_walls(state), 0.0, m).astype(b.dtype)
        if diagonal and self.pressure is not None:  # m + share, where the fields are
            m = arrays.added(m, self.pressure.diagonal_mirror())
        return m

    @staticmethod
    def _mirror_field(state: SimState) -> np.ndarray:
        b = state.boundary
        if "pressure_mirror" in b.specs and b["pressure_mirror"].shape[0] == b.n:
            return b["pressure_mirror"]
        return arrays.zeros(b.n, b.dtype, like=b["x"])

    def boundary_kappa(self, state: SimState) -> BoundaryKappa:
        """The extrapolation ``k -> k_b`` of this step's pressure fields (see
        :class:`BoundaryKappa`)."""
        model = (None if self.symmetric or (self.solved and not self.stratified)
                 else self.pressure)
        return BoundaryKappa(model, state, self._kb_array(model, state))

    def _kb_array(self, model: BoundaryPressure | None, state: SimState) -> np.ndarray:
        """The array a model's ``k_b`` go into, one for every solve: zeros when made (a new
        shape, type or device), and the model writes only the samples it extrapolates
        (:meth:`BoundaryPressure.extrapolate`), so the others stay 0, as the pressure terms
        read them; an extrapolated sample without fluid neighbours in this step keeps an
        older value, which no term reads (the terms read a fluid particle's boundary
        neighbours). Empty without a model (mirroring only)."""
        f = state.fluid
        if model is None:
            return arrays.absent(0, f.dtype, like=f["x"])
        n = state.boundary.n
        shape = (model.phases, n) if model.phase is not None else (n,)
        kb = self._kb
        if (kb is None or kb.shape != shape or kb.dtype != f.dtype
                or device_of(kb) != device_of(f["x"])):
            kb = self._kb = arrays.zeros(shape, f.dtype, like=f["x"])
        return kb

    def symmetric_walls(self, state: SimState) -> np.ndarray:
        """Which boundary particles take the symmetric term ``V_b k_i`` (no mirrored share, no
        extrapolated ``k_b``): all with ``symmetric``; with ``solved`` the static walls
        (:meth:`solved_walls`), not rigid bodies; none otherwise. The mask of :meth:`mirror`'s
        zeros for WCSPH, whose boundary term mirrors every boundary particle otherwise; with
        ``symmetric`` on the device of the boundary's fields (WCSPH's step runs there too)."""
        if self.symmetric:
            return arrays.full(state.boundary.n, True, np.bool_, like=state.boundary["x"])
        return self.solved_walls(state)

    def one_sided_bodies(self, state: SimState) -> np.ndarray | None:
        """The boundary samples (N_boundary,) bool of moving bodies whose mirror weight
        ``pressure_mirror`` is 0 (moving density and volume maps; Akinci bodies mirror, 1), or
        None where there are none: where WCSPH, whose boundary term mirrors every boundary
        otherwise, takes the one-sided term of the PPE solvers (:mod:`sphkit.pressure.wcsph`).
        Moving bodies run on the CPU only (``scene.checks``)."""
        b = state.boundary
        if not b.n or not self.reacts:
            return None
        use = (b["rigid_body"] > 0) & (b["pressure_mirror"] == 0.0)
        return use if use.any() else None

    def solved_walls(self, state: SimState) -> np.ndarray:
        """Which boundary particles carry a pressure of their own that the PPE solvers solve
        for (scene ``configuration.boundary.solved``; static walls, not rigid bodies; all
        False when off). Their boundary term is ``-sum_b V_b (k_i + k_b) grad W_ib`` with
        ``k_b >= 0`` chosen in the same Jacobi iteration as the fluid's so that the fluid's
        normalized density at the wall particle, ``sum_f V_f W_fb``, does not change in the
        step (:func:`sphkit.core.solver.jacobi_ppe`). The force is then the transpose of
        that constraint (a Lagrange multiplier's): it does no work on a flow that keeps it,
        unlike the mirrored or extrapolated ``k_b``, whose share beyond ``V_b k_i`` made a
        closed box of fluid at rest gain energy (``validation/wall_energy.py``). After Band
        et al. 2018, "Pressure boundaries for implicit incompressible SPH" (ACM TOG 37(2)),
        whose extended PPE gives boundary samples a pressure of their own; the paper itself
        could not be read here: the constraint (the fluid density at the wall held, velocity
        level) and its Jacobi update are sphkit's. ``solved: "density"`` holds the density
        itself at its rest value in the density solves (:meth:`wall_rest`); it does not make
        the split of the support between ``k_b`` and the fluid's pressure unique
        (validation/README.md, "Solved walls at density level"). ``solved: "stratified"``
        solves only the rows of :meth:`_stratified_rows` (the others keep the boundary
        pressure model's ``k_b``, :func:`sphkit.core.solver.solved_kappa`)."""
        static = self._static_walls(state)
        return static & self._stratified_rows(state) if self.stratified else static

    def _static_walls(self, state: SimState) -> np.ndarray:
        """The boundary particles that may be solved: the static walls, not rigid bodies (all
        False when the walls are not solved)."""
        b = state.boundary
        if not self.solved:
            return np.zeros(b.n, dtype=np.bool_)
        if "rigid_body" in b.specs and b["rigid_body"].shape[0] == b.n:
            return b["rigid_body"] == 0
        return np.ones(b.n, dtype=np.bool_)

    def _stratified_rows(self, state: SimState) -> np.ndarray:
        """``solved: "stratified"``: the boundary particles among whose fluid neighbours a
        particle of a lighter fluid lies lower (against gravity) than one of the heaviest
        fluid, i.e. where the fluid beside the wall is stratified the unstable way (computed
        once per step and neighbour list). There the walls' rows keep a heavy-over-light
        overturn stable, where the extrapolated (MLS) pressure threw light particles up the
        walls; elsewhere the MLS pressure carries a column at rest without the rows' excess
        beside 2D side walls (validation/README.md, "Solved walls where the fluid is
        stratified")."""
        b, f = state.boundary, state.fluid
        boff, bidx = state.nl_fb.offsets, state.nl_fb.indices
        key = (state.step, id(bidx))
        if self._rows is not None and self._rows[:2] == key and self._rows[2].shape[0] == b.n:
            return self._rows[2]
        out = np.zeros(b.n, dtype=np.bool_)
        if f.n and boff.shape[0] == f.n + 1 and bidx.shape[0]:
            rho0 = np.asarray(f["rho0"])
            rows = np.repeat(np.arange(f.n), np.diff(boff))
            light = (rho0 < rho0.max())[rows]
            g = np.asarray(state.gravity, dtype=np.float64)
            up = -g / max(float(np.linalg.norm(g)), 1e-300)
            height = (up @ np.asarray(f["x"], dtype=np.float64))[rows]
            top_heavy = np.full(b.n, -np.inf)
            low_light = np.full(b.n, np.inf)
            np.maximum.at(top_heavy, bidx[~light], height[~light])
            np.minimum.at(low_light, bidx[light], height[light])
            out = low_light < top_heavy
        self._rows = (*key, out)
        return out

    def wall_rest(self, state: SimState) -> np.ndarray:
        """The rest value of the fluid's normalized density ``rho_hat_b = sum_f V_f W_fb`` at
        each solved wall particle (``solved: "density"``): its value at the first density
        solve that sees it (the run's start, after :mod:`sphkit.world.startup`) where the
        wall particle is *covered* then -- it has fluid neighbours and every one of them has
        a filled kernel (``rho / rho0 >= 1 -`` :data:`COVERED_TOLERANCE`) --, else -2 (the
        wall particle keeps the velocity-level constraint, that of ``solved: true``); -1 where
        not yet computed. Kept in the boundary field ``wall_rest`` (so checkpoints keep it).
        With ``solved: "stratified"`` a wall particle that becomes a row later in the flow
        takes its value at that solve (where it is covered then): the start value, held from
        a later moment, pushed the fluid there at once and PCISPH's 1:10 overturn blew up at
        1.69 s (validation/README.md, "Solved walls where the fluid is stratified").

        Why the start value: the start-up sets every fluid mass so that its density is exactly
        its start density (rest density for the incompressible solvers) with the walls as
        they stand, so the start configuration satisfies every fluid row and every wall row
        at once, whatever the walls' shape (faces, edges, corners, meshes) and wherever the
        start-up's relaxation moved the first fluid row. A value from the wall geometry (the
        box's interior sampling lattice) was measured against it at the 2D column's walls: the
        start values were 0.76-0.78 of it along the side walls (the relaxation moves the first
        row away from Akinci walls), so the walls' rows would be slack at rest. Why only
        covered wall particles: at a free surface or where no fluid is at the start, the start
        value is a partial one; holding it would push fluid that arrives later (sloshing, a
        dam break's far wall) away from the wall, so those particles hold the rate only."""
        b = state.boundary
        if "wall_rest" not in b.specs:
            b.register("wall_rest", fill=-1.0)
        rest = b["wall_rest"]
        use = self.solved_walls(state)
        new = use & (rest == -1.0)
        if new.any():
            f = state.fluid
            rho_b = self.wall_density(state, new)
            boff, bidx = state.nl_fb.offsets, state.nl_fb.indices
            rows = np.repeat(np.arange(f.n), np.diff(boff))
            filled = (f["rho"] / f["rho0"] >= 1.0 - COVERED_TOLERANCE)[rows]
            seen = np.bincount(bidx, minlength=b.n) > 0
            thin = np.bincount(bidx, weights=(~filled).astype(np.float64), minlength=b.n) > 0
            covered = seen & ~thin
            rest[new] = np.where(covered[new], rho_b[new], -2.0)
        return rest

    def wall_density(self, state: SimState, use: np.ndarray) -> np.ndarray:
        """The fluid's normalized density ``sum_f V_f W_fb`` at the boundary particles with
        ``use`` (0 elsewhere; :func:`sphkit.core.solved_walls.wall_density`)."""
        from sphkit.core.pairs import period_arg
        from sphkit.core.solved_walls import wall_density

        f, b = state.fluid, state.boundary
        rest = state.rest()
        Vf = f["V0"] if rest.uniform else rest.V
        out = np.empty(b.n, dtype=f.dtype)
        wall_density(f["x"], Vf, b["x"], state.nl_fb.offsets, state.nl_fb.indices, state.h,
                     state.kid, state.dim, period_arg(state.pair_period), use, out)
        return out

    def wall_kappa(self, state: SimState, key: str) -> np.ndarray:
        """The solved walls' ``k_b`` of the solve named ``key`` (its warm start: the last
        step's values; zeros at first): the boundary field ``wall_kappa_<key>``, so that it
        moves with the boundary particles and checkpoints keep it (a resumed run repeats the
        uninterrupted one; a checkpoint written without it restores zeros)."""
        return state.boundary.register(f"wall_kappa_{key}", optional=True)

    def prepare(self, state: SimState) -> None:
        """Once per step after the densities (the MLS coefficients of this step's pairs)."""
        if self.pressure is not None:
            self.pressure.prepare(state)

    def correct_mirrored(self, state: SimState, a: np.ndarray) -> None:
        """A state-equation solver's correction from mirrored to the model's ``p_b``."""
        if self.pressure is not None:
            self.pressure.correct_mirrored(state, a)

    # -- moving boundaries ----------------------------------------------------------------------
    @property
    def yields(self) -> bool:
        """Whether some boundary yields to the pressure (strong coupling is on)."""
        return self.moving is not None and self.moving.yields

    def motion(self, state: SimState, forces: np.ndarray | None,
               dt: float) -> np.ndarray | None:
        """The yielding bodies' rigid displacement (bodies, 6) in the step under the summed
        forces and torques ``forces`` of a positional solve so far (PBF's sweeps; None: none
        yet), :meth:`MovingBoundary.motion`; None when nothing yields (the boundary stays at
        the step start)."""
        return self.moving.motion(forces, dt) if self.yields else None

    def yielding(self, state: SimState, body: np.ndarray) -> np.ndarray | None:
        """Which boundary samples with the body numbers ``body`` (:meth:`boundary_at`) yield
        (bool); None when nothing yields."""
        return self.moving.yielding(state, body) if self.yields else None

    def predict(self, state: SimState, dt: float) -> None:
        """Before the pressure solve: the yielding boundary's non-pressure velocity change."""
        if self.yields:
            self.moving.predict(state, dt)

    def response(self, state: SimState, k: np.ndarray, gwb: np.ndarray) -> np.ndarray:
        """Boundary accelerations (dim, N_boundary) under the solver field k (zeros when no
        boundary yields: then the pressure does not accelerate the boundary)."""
        if self.yields:
            return self.moving.response(k, gwb)
        x = state.boundary["x"]
        if (self._still.shape != x.shape or self._still.dtype != x.dtype
                or device_of(self._still) != device_of(x)):
            self._still = arrays.zeros(x.shape, x.dtype, like=x)
        return self._still

    def take_impulse(self, state: SimState, k: np.ndarray, gwb: np.ndarray, dt: float) -> None:
        """The yielding boundary takes the velocity change ``dt a_b(k)`` of a solve that
        applied the pressure impulse of k to the fluid (DFSPH's divergence solve), so that a
        later solve sees the boundary as the fluid does."""
        if self.yields:
            state.boundary["v"] += dt * self.moving.response(k, gwb)

    def displacement(self, state: SimState, k: np.ndarray, gwb: np.ndarray,
                     dt: float) -> np.ndarray:
        """Predicted displacement of the yielding boundary particles under the field k,
        ``dt (v_b + dt a_b(k))`` where the boundary yields and 0 elsewhere (PCISPH's predicted
        positions); an empty array when nothing yields (the static boundary stays put)."""
        if not self.yields:  # where the boundary is (a device array on the device)
            return arrays.absent((state.dim, 0), state.boundary.dtype, like=state.boundary["x"])
        ab = self.moving.response(k, gwb)
        return np.where(self.moving.yielding(state), dt * (state.boundary["v"] + dt * ab), 0.0)


class BoundaryKappa:
    """The boundary values ``k_b = p_b / rho0`` that :func:`sphkit.core.ppe.kappa_accel_cached`
    adds to its boundary term: extrapolated from the fluid field k by a
    :class:`BoundaryPressure` model when the scene has one, else none (an empty array, which the
    pass reads as 0: mirroring only)."""

    def __init__(self, model: BoundaryPressure | None, state: SimState, kb: np.ndarray) -> None:
        """``kb``: the array the values go into (:meth:`BoundaryCoupling.boundary_kappa`'s,
        empty without a model)."""
        self.model = model
        #: the fluid's phases where the model gives each phase its own k_b (several rest
        #: densities: ``kb`` is then (phases, N_boundary)), else None
        self.phase = model.phase if model is not None else None
        self.kb = kb

    def __call__(self, k: np.ndarray) -> np.ndarray:
        """``k_b`` for the fluid field k (``k_b[q, b]`` per phase q where :attr:`phase` is
        set)."""
        if self.model is not None:
            self.model.extrapolate(k, self.kb)
        return self.kb
