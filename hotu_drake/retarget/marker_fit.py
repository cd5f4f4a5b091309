"""Fit the unified digital human to measured markers (the accurate C3D path).

Per frame, a Drake `InverseKinematics` program over the floating-base UDH
minimises the squared distances between the UDH's virtual markers (the
marker set's placements, see `hotu_drake.motion.c3d.udh_markers`) and the
measured ones, with joint limits as bounds and a small smoothness term
towards the previous frame (which also holds DoFs the markers do not
observe); SNOPT solves it, warm-started from the previous frame.

SNOPT's quasi-Newton Hessian alone needs about a hundred evaluations per
frame (~200 ms); IPOPT hits its iteration limit (~10 s). So a few
Levenberg-Marquardt steps on the same objective (Drake Jacobians, a 40 x 40
solve each) first bring the warm start to the optimum, where SNOPT only
has to confirm it: about 4 ms a frame in all on one core.

Gap-filled samples are data like any other; to leave them out, set them to
NaN (`read_c3d`'s `info["filled"]` marks them).
"""

from collections.abc import Mapping

import numpy as np

from hotu_drake.embodiment import Embodiment
from hotu_drake.embodiment.kinematics import batch_link_poses
from hotu_drake.motion.clip import ClipFormatError, MotionClip
from hotu_drake.motion.marker_sets import MarkerSetLike, marker_placements, markers_to_landmarks, udh_markers
from hotu_drake.rotations import quat_to_matrix

MARKER_WEIGHT = 100.0  # per marker, on squared metres
SMOOTHNESS = 1e-3  # on squared change of every position from the previous frame
MIN_MARKERS = 4
NOMINAL_HEIGHT = 1.61
NOMINAL_LEG = 0.4215 + 0.4099  # hip -> knee -> ankle of the nominal UDH


def fit_udh_to_markers(
    markers: Mapping[str, np.ndarray],
    fps: float,
    udh: Embodiment | None = None,
    marker_set: MarkerSetLike = None,
    *,
    source: str = "markers",
    smoothness: float = SMOOTHNESS,
) -> MotionClip:
    """A UDH clip (joints, root pose, velocities, key bodies) fitted to {marker: (T, 3)}.

    `udh` defaults to a hands-free UDH sized to the performer's leg length
    (from the marker set's hip, knee and ankle centres, else 1.61 m). NaN
    samples are left out of their frame's fit.
    """
    data, names = _marker_array(markers, source)
    if not np.isfinite(fps) or fps <= 0:
        raise ClipFormatError(f"{source}: fps must be a positive number")
    if udh is None:
        udh = _sized_udh(markers, marker_set)
    placements = marker_placements(udh, marker_set)
    used = [i for i, name in enumerate(names) if name in placements]
    if len(used) < MIN_MARKERS:
        raise ClipFormatError(f"{source}: only {len(used)} markers have a place on the UDH (need {MIN_MARKERS})")
    fit = _Fit(udh, [placements[names[i]] for i in used], smoothness)
    q = fit.solve_all(data[:, used])
    return _clip(udh, fit, q, fps, source)


def marker_residuals(
    udh: Embodiment, clip: MotionClip, markers: Mapping[str, np.ndarray], marker_set: MarkerSetLike = None
) -> dict[str, float]:
    """RMS distance (metres) per marker between a UDH clip's virtual markers and measured ones."""
    virtual = udh_markers(udh, clip, marker_set)
    out = {}
    for name, measured in markers.items():
        if name in virtual:
            error = np.linalg.norm(virtual[name] - np.asarray(measured, dtype=float), axis=-1)
            out[name] = float(np.sqrt(np.nanmean(error**2)))
    return out


def _marker_array(markers: Mapping[str, np.ndarray], source: str) -> tuple[np.ndarray, list[str]]:
    """(T, n, 3) array and names; checks shapes."""
    names = list(markers)
    if not names:
        raise ClipFormatError(f"{source}: no markers")
    arrays = [np.asarray(markers[name], dtype=float) for name in names]
    frames = arrays[0].shape[0] if arrays[0].ndim == 2 else -1
    if frames <= 0 or any(a.shape != (frames, 3) for a in arrays):
        raise ClipFormatError(f"{source}: markers must be (T, 3) arrays of one length T > 0")
    return np.stack(arrays, axis=1), names


def _sized_udh(markers: Mapping[str, np.ndarray], marker_set: MarkerSetLike) -> Embodiment:
    """A hands-free UDH scaled to the leg length the markers show (nominal if unknown)."""
    from hotu_drake.embodiment import load

    height = NOMINAL_HEIGHT
    try:
        lm = markers_to_landmarks(markers, marker_set)
        legs = [
            np.linalg.norm(lm[f"{s}_knee"] - lm[f"{s}_hip"], axis=-1)
            + np.linalg.norm(lm[f"{s}_ankle"] - lm[f"{s}_knee"], axis=-1)
            for s in ("left", "right")
        ]
        leg = float(np.nanmedian(np.concatenate(legs)))
        if np.isfinite(leg):
            height = float(np.clip(round(NOMINAL_HEIGHT * leg / NOMINAL_LEG, 3), 0.5, 2.5))
    except (ClipFormatError, KeyError):
        pass
    return load("udh", hands="none", height=height)


class _Fit:
    """The UDH plant, marker frames and the per-frame IK solve."""

    def __init__(self, udh: Embodiment, placements: list[tuple[str, np.ndarray]], smoothness: float):
        from pydrake.multibody.plant import MultibodyPlant
        from pydrake.solvers import SnoptSolver

        self.udh = udh
        self.plant = MultibodyPlant(0.0)
        udh.add_to_plant(self.plant)
        self.plant.Finalize()
        self.context = self.plant.CreateDefaultContext()
        self.frames = [self.plant.GetBodyByName(link).body_frame() for link, _ in placements]
        self.offsets = [np.asarray(offset, dtype=float) for _, offset in placements]
        self.links = [link for link, _ in placements]
        by_link: dict[str, list[int]] = {}
        for i, link in enumerate(self.links):
            by_link.setdefault(link, []).append(i)
        self.groups = [
            (
                self.plant.GetBodyByName(link).body_frame(),
                np.array(index),
                np.stack([self.offsets[i] for i in index], 1),
            )
            for link, index in by_link.items()
        ]
        root = self.plant.GetBodyByName(udh.spec.root.name)
        self.root_q = root.floating_positions_start()
        self.joint_q = np.array([self.plant.GetJointByName(n).position_start() for n in udh.joint_names])
        self.lower = self.plant.GetPositionLowerLimits()[self.joint_q]
        self.upper = self.plant.GetPositionUpperLimits()[self.joint_q]
        self.solver = SnoptSolver()
        self.smoothness = smoothness

    def solve_all(self, measured: np.ndarray) -> np.ndarray:
        """(T, nq) plant positions fitted to measured (T, n, 3), warm-started frame to frame."""
        q = self.initial_guess(measured[0])
        out = np.empty((len(measured), self.plant.num_positions()))
        for t, frame in enumerate(measured):
            q = self.solve_frame(frame, q, first=t == 0)
            out[t] = q
        return out

    def solve_frame(self, measured: np.ndarray, q_previous: np.ndarray, first: bool = False) -> np.ndarray:
        """Plant positions fitting one frame of markers (n, 3); NaN markers are skipped.

        Levenberg-Marquardt steps on the same objective bring the warm start
        to the optimum (cheap: Drake Jacobians, one 40 x 40 solve a step);
        SNOPT then solves the IK program from there, which costs little more
        than checking optimality. Without them SNOPT's quasi-Newton Hessian
        needs about a hundred evaluations per frame.
        """
        valid = np.all(np.isfinite(measured), axis=1)
        # On the first frame the "previous" pose is only the initial guess: hold it weakly.
        smoothness = self.smoothness * (0.1 if first else 1.0)
        q = self._levenberg_marquardt(measured, valid, q_previous, q_previous, smoothness, 30 if first else 6)
        polished = self._solve_ik(measured, valid, q, q_previous, smoothness)
        # Keep the better of the two should the solver stop early.
        costs = [self._objective(x, measured, valid, q_previous, smoothness)[0] for x in (q, polished)]
        return polished if costs[1] <= costs[0] else q

    def _solve_ik(self, measured, valid, q_start, q_previous, smoothness) -> np.ndarray:
        """The per-frame Drake IK program (position costs, joint limits, smoothness), solved from `q_start`."""
        from pydrake.multibody.inverse_kinematics import InverseKinematics

        ik = InverseKinematics(self.plant, self.context, with_joint_limits=True)
        world = self.plant.world_frame()
        weight = MARKER_WEIGHT * np.eye(3)
        for i in np.flatnonzero(valid):
            ik.AddPositionCost(world, measured[i], self.frames[i], self.offsets[i], weight)
        prog = ik.get_mutable_prog()
        prog.AddQuadraticErrorCost(smoothness * np.eye(len(q_previous)), q_previous, ik.q())
        prog.SetInitialGuess(ik.q(), q_start)
        q = self.solver.Solve(prog).GetSolution(ik.q())
        if not np.all(np.isfinite(q)):
            return q_start
        q = q.copy()
        q[self.root_q : self.root_q + 4] /= np.linalg.norm(q[self.root_q : self.root_q + 4])
        return q

    def _markers(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World marker positions (n, 3) and their Jacobian d p / d q (n, 3, nq)."""
        from pydrake.multibody.tree import JacobianWrtVariable

        self.plant.SetPositions(self.context, q)
        world = self.plant.world_frame()
        nq = self.plant.num_positions()
        positions = np.empty((len(self.frames), 3))
        jacobian = np.empty((len(self.frames), 3, nq))
        for frame, index, points in self.groups:
            positions[index] = self.plant.CalcPointsPositions(self.context, frame, points, world).T
            jacobian[index] = self.plant.CalcJacobianTranslationalVelocity(
                self.context, JacobianWrtVariable.kQDot, frame, points, world, world
            ).reshape(len(index), 3, nq)
        return positions, jacobian

    def _objective(self, q, measured, valid, q_previous, smoothness):
        """(cost, weighted residual rows, their Jacobian) of the per-frame objective."""
        positions, jacobian = self._markers(q)
        residual = (positions - measured)[valid].reshape(-1)
        cost = MARKER_WEIGHT * residual @ residual + smoothness * np.sum((q - q_previous) ** 2)
        return cost, residual, jacobian[valid].reshape(len(residual), -1)

    def _tangent_basis(self, q: np.ndarray) -> np.ndarray:
        """(nq, nq - 1) orthonormal basis of steps that keep the root quaternion unit to first order."""
        w, x, y, z = q[self.root_q : self.root_q + 4]
        nq = len(q)
        basis = np.zeros((nq, nq - 1))
        basis[self.root_q : self.root_q + 4, :3] = [[-x, -y, -z], [w, -z, y], [z, w, -x], [-y, x, w]]
        rest = [i for i in range(nq) if not self.root_q <= i < self.root_q + 4]
        basis[rest, 3:] = np.eye(nq - 4)
        return basis

    def _retract(self, q: np.ndarray, step: np.ndarray) -> np.ndarray:
        """q + step with the quaternion renormalised and the joints clipped to their limits."""
        out = q + step
        out[self.root_q : self.root_q + 4] /= np.linalg.norm(out[self.root_q : self.root_q + 4])
        out[self.joint_q] = np.clip(out[self.joint_q], self.lower, self.upper)
        return out

    def _levenberg_marquardt(self, measured, valid, q, q_previous, smoothness, iterations) -> np.ndarray:
        """Damped Gauss-Newton on the per-frame objective, projected onto the joint limits."""
        cost, residual, jacobian = self._objective(q, measured, valid, q_previous, smoothness)
        damping = 1e-6
        for _ in range(iterations):
            basis = self._tangent_basis(q)
            reduced = jacobian @ basis
            gradient = basis.T @ (MARKER_WEIGHT * jacobian.T @ residual + smoothness * (q - q_previous))
            hessian = MARKER_WEIGHT * reduced.T @ reduced + smoothness * np.eye(basis.shape[1])
            while True:
                lhs = hessian + damping * np.diag(np.diag(hessian) + 1e-9)
                trial = self._retract(q, basis @ np.linalg.solve(lhs, -gradient))
                trial_cost, trial_residual, trial_jacobian = self._objective(
                    trial, measured, valid, q_previous, smoothness
                )
                if trial_cost <= cost or damping > 1e6:
                    break
                damping *= 10.0
            if trial_cost > cost:
                break
            improvement = cost - trial_cost
            q, cost, residual, jacobian = trial, trial_cost, trial_residual, trial_jacobian
            damping = max(damping / 10.0, 1e-9)
            if improvement <= 1e-12 * (1.0 + cost):
                break
        return q

    def initial_guess(self, measured: np.ndarray) -> np.ndarray:
        """Standing pose with the root placed by a rigid (Kabsch) fit of the markers:
        those on the root link if at least three are seen, else all."""
        q = self.plant.GetPositions(self.context).copy()
        q[self.joint_q] = self.udh.standing_pose
        poses = batch_link_poses(self.udh.spec, self.udh.joint_names, self.udh.standing_pose[None])
        model = np.array([poses[link][1][0] + poses[link][0][0] @ off for link, off in zip(self.links, self.offsets)])
        seen = np.all(np.isfinite(measured), axis=1)
        on_root = seen & np.array([link == self.udh.spec.root.name for link in self.links])
        use = on_root if on_root.sum() >= 3 else seen
        rotation, translation = _kabsch(model[use], measured[use])
        from pydrake.math import RotationMatrix

        q[self.root_q : self.root_q + 4] = RotationMatrix(rotation).ToQuaternion().wxyz()
        q[self.root_q + 4 : self.root_q + 7] = translation
        return q


def _kabsch(model: np.ndarray, measured: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t minimising |R model + t - measured|^2."""
    if len(model) < 3:
        return np.eye(3), measured.mean(axis=0) - model.mean(axis=0) if len(model) else np.zeros(3)
    a, b = model - model.mean(axis=0), measured - measured.mean(axis=0)
    u, _, vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(u @ vt))
    rotation = u @ np.diag([1.0, 1.0, d]) @ vt
    return rotation, measured.mean(axis=0) - rotation @ model.mean(axis=0)


def _clip(udh: Embodiment, fit: _Fit, q: np.ndarray, fps: float, source: str) -> MotionClip:
    """The fitted plant positions as a UDH `MotionClip` with velocities and key bodies."""
    quaternion = q[:, fit.root_q : fit.root_q + 4]
    root_position = q[:, fit.root_q + 4 : fit.root_q + 7]
    joints = q[:, fit.joint_q]
    poses = batch_link_poses(udh.spec, udh.joint_names, joints, quat_to_matrix(quaternion), root_position)
    links = list(dict.fromkeys(udh.key_bodies.values()))  # key-body links, as the retargeter names them
    key_positions = np.stack([poses[link][1] for link in links], axis=1)
    return MotionClip.from_positions(
        udh.name,
        source,
        fps,
        udh.joint_names,
        joints,
        root_position,
        quaternion,
        links,
        key_positions,
        part_index={part: list(joints) for part, joints in udh.parts.items()},
    )
