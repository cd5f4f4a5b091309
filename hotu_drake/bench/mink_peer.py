"""A peer for the retargeting benchmark: mink's differential IK on our MJCF export.

The set-up follows GMR (general motion retargeting), which retargets with
mink: per frame, the human's body positions (scaled to the robot) and the
body orientations the source defines become `FrameTask` targets on the
matching robot frames, and two IK stages run one after the other, each
solving `mink.solve_ik` and integrating the step while the stage's task
error keeps falling (by more than 1e-3, at most 11 solves a stage), warm
started from the previous frame. Stage 1 weights the root and feet
positions and the body orientations; stage 2 every landmark's position and
the orientations. Joint limits are mink's `ConfigurationLimit`, joint
speeds its `VelocityLimit` at 3 pi rad/s (GMR's default); the QP solver
is DAQP through qpsolvers, the integration step the model's time step.

Our landmarks stand in for GMR's matched bodies: each task acts on a MuJoCo
site added to the exported model at the landmark's place on its link (a
joint's landmark is the child link's origin, as GMR's body frames are).
Positions are scaled as the method scales the root: by the ratio of the
robot's leg length to the source's, about the pelvis. Body frames (pelvis,
chest, hands, feet) come from the same landmark constructions as the
method's (`hotu_drake.retarget.frames`), composed with the robot's rest
frame. A robot without legs (CURI's wheeled base) keeps its scale; its
targets are shifted so that the source chest sits at the robot's rest chest
height, and its base follows the pelvis over the floor only.

This needs the `mink` extra (`pip install 'hotu-drake[mink]'`).
"""

from __future__ import annotations

import time

import numpy as np

from hotu_drake import embodiment
from hotu_drake.embodiment.formats.mjcf import to_mjcf
from hotu_drake.embodiment.landmarks import landmark_placements
from hotu_drake.embodiment.spec import SIDES
from hotu_drake.motion.clip import MotionClip
from hotu_drake.motion.human import landmarks_of
from hotu_drake.retarget import frames
from hotu_drake.retarget.retargeter import leg_length

SOLVER = "daqp"
DAMPING = 0.5  # the solver's Levenberg-Marquardt damping (GMR's)
TASK_DAMPING = 1.0  # each frame task's own LM damping (GMR's)
MAX_ITERATIONS = 10  # further solves a stage may take after its first (GMR's)
MIN_ERROR_DROP = 1e-3  # a stage goes on while its task error falls by more than this
VELOCITY_LIMIT = 3.0 * np.pi  # rad/s (m/s on a slide joint), GMR's default
SKIP_MESSAGE = "mink with DAQP is not installed (pip install 'hotu-drake[mink]')"

# The landmarks that get a frame task, in the spirit of GMR's body tables
# (root, torso, and each limb's joints and end), and the body frame each
# oriented one carries.
TASK_LANDMARKS = (
    "pelvis",
    "chest",
    *(f"{side}_{name}" for side in SIDES for name in ("shoulder", "elbow", "wrist", "hand")),
    *(f"{side}_{name}" for side in SIDES for name in ("hip", "knee", "ankle", "toe")),
)
FRAME_OF = {"pelvis": "pelvis", "chest": "chest", **{f"{s}_hand": f"{s}_hand" for s in SIDES}}
FRAME_OF.update({f"{s}_toe": f"{s}_foot" for s in SIDES})
# (position cost, orientation cost) per stage, as GMR weights its tables:
# stage 1 pins the root and feet and turns the bodies; stage 2 places every
# landmark. A landmark without a body frame gets no orientation cost.
ROOT_AND_FEET = {"pelvis", *(f"{s}_toe" for s in SIDES)}
STAGE_1 = {name: (100.0 if name in ROOT_AND_FEET else 0.0, 10.0) for name in FRAME_OF}
STAGE_2 = {name: (100.0 if name in ROOT_AND_FEET else 10.0, 5.0) for name in TASK_LANDMARKS}
STAGE_2.update({f"{s}_toe": (100.0, 50.0) for s in SIDES})


def mink_available() -> bool:
    """Whether mink and the DAQP solver (through qpsolvers) can be imported."""
    try:
        import mink  # noqa: F401
        import qpsolvers
    except ImportError:
        return False
    return SOLVER in qpsolvers.available_solvers


def _frame_names(names: set[str]) -> set[str]:
    """The body frames that landmarks `names` define."""
    out = set()
    if {"chest", "neck", "left_shoulder", "right_shoulder"} <= names:
        out.add("chest")
    if {"pelvis", "left_hip", "right_hip"} <= names and ("spine" in names or "chest" in names):
        out.add("pelvis")
    for side in SIDES:
        if {f"{side}_{n}" for n in ("wrist", "hand", "index_1", "little_1")} <= names:
            out.add(f"{side}_hand")
        if {f"{side}_ankle", f"{side}_toe"} <= names and "pelvis" in out:
            out.add(f"{side}_foot")
    return out


def _body_frames(p: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Body frames from landmark positions (one frame or a trajectory), where the landmarks allow."""
    available = _frame_names(set(p))
    out = {}
    if "chest" in available:
        out["chest"] = frames.chest_frame(p)
    if "pelvis" in available:
        out["pelvis"] = frames.pelvis_frame(p)
    for side in SIDES:
        if f"{side}_hand" in available:
            out[f"{side}_hand"] = frames.hand_frame(p, side)
        if f"{side}_foot" in available:
            out[f"{side}_foot"] = frames.foot_frame(p, side, out["pelvis"][..., :, 1])
    return out


def _quat_wxyz(rotations: np.ndarray) -> np.ndarray:
    """Unit quaternions (w, x, y, z) of rotation matrices (..., 3, 3)."""
    import mujoco

    flat = rotations.reshape(-1, 9)
    out = np.empty((len(flat), 4))
    for i, matrix in enumerate(flat):
        mujoco.mju_mat2Quat(out[i], matrix)
    return out.reshape(*rotations.shape[:-2], 4)


class _Peer:
    """The robot's MJCF with a site per task landmark, and mink's IK set-up on it."""

    def __init__(self, robot: str, hands: str, source_names: set[str]):
        import mink
        import mujoco

        self.emb = embodiment.load(robot, hands)
        spec = self.emb.spec
        placements = landmark_placements(spec)
        self.names = [n for n in TASK_LANDMARKS if n in placements and n in source_names]
        mj = mujoco.MjSpec.from_string(to_mjcf(spec))
        for name in self.names:
            link, offset = placements[name]
            mj.body(link).add_site(name=name, pos=np.asarray(offset, dtype=float))
        self.model = mj.compile()
        # Links are world-aligned at q = 0 with the root at the origin, so the
        # rest landmarks are link origins plus offsets.
        self.rest = {n: np.asarray(spec.link(link).origin, dtype=float) + off for n, (link, off) in placements.items()}
        legs = {f"{s}_{n}" for s in SIDES for n in ("hip", "knee", "ankle")} | {"pelvis"}
        self.legged = legs <= set(self.rest) and legs <= source_names
        rest_frames, source_frames = _body_frames(self.rest), _frame_names(source_names)
        both = source_frames & set(rest_frames)
        self.oriented = {n: rest_frames[FRAME_OF[n]] for n in self.names if FRAME_OF.get(n) in both}

        q = self.model.qpos0.copy()
        for name, value in zip(self.emb.joint_names, self.emb.standing_pose):
            q[self.model.joint(name).qposadr[0]] = value
        if self.emb.floating_base:
            q[:7] = [0.0, 0.0, self.emb.standing_root_height, 1.0, 0.0, 0.0, 0.0]
        self.configuration = mink.Configuration(self.model, q)
        joints = [mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_JOINT, j) for j in range(self.model.njnt)]
        speeds = {
            n: VELOCITY_LIMIT for j, n in enumerate(joints) if self.model.jnt_type[j] != mujoco.mjtJoint.mjJNT_FREE
        }
        self.limits = [mink.ConfigurationLimit(self.model), mink.VelocityLimit(self.model, speeds)]
        # Without legs to scale by (CURI's planar base cannot rise), the root task holds the pelvis over the floor.
        self.position_mask = {n: np.ones(3) for n in self.names}
        if not self.legged and "pelvis" in self.position_mask:
            self.position_mask["pelvis"] = np.array([1.0, 1.0, 0.0])
        self.stages = [tasks for tasks in (self._tasks(STAGE_1), self._tasks(STAGE_2)) if tasks]

    def _tasks(self, weights: dict[str, tuple[float, float]]) -> list[tuple[object, str, np.ndarray]]:
        """(task, landmark, error mask) for the landmarks this stage weights."""
        import mink

        out = []
        for name in self.names:
            position, orientation = weights.get(name, (0.0, 0.0))
            if name not in self.oriented:
                orientation = 0.0
            if position == 0.0 and orientation == 0.0:
                continue
            task = mink.FrameTask(
                name, "site", position * self.position_mask[name], orientation, lm_damping=TASK_DAMPING
            )
            # The stage's error counts what has a target: positions, and orientations where the source has a frame.
            mask = np.concatenate([self.position_mask[name], np.ones(3) if name in self.oriented else np.zeros(3)])
            out.append((task, name, mask))
        return out

    def targets(self, src: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
        """Per landmark: target positions (T, 3), and target link rotations as quaternions (T, 4) where oriented."""
        if self.legged:  # the root follows the pelvis scaled by the leg ratio; every offset from it likewise
            ratio = leg_length(self.rest) / leg_length(src)
            anchor = src["pelvis"] * ratio
            positions = {n: anchor + (src[n] - src["pelvis"]) * ratio for n in self.names}
        else:  # no legs to scale by: the source chest at the robot's rest chest height
            lift = self.rest["chest"][2] - src["chest"][:, 2]
            shift = np.stack([np.zeros_like(lift), np.zeros_like(lift), lift], axis=-1)
            positions = {n: src[n] + shift for n in self.names}
        source_frames = _body_frames(src)
        # The link turns the robot's rest frame onto the source's.
        rotations = {n: _quat_wxyz(source_frames[FRAME_OF[n]] @ rest.T) for n, rest in self.oriented.items()}
        return positions, rotations

    def solve(self, positions: dict, rotations: dict, frame_count: int) -> tuple[np.ndarray, int]:
        """Joint configurations (T, nq) frame by frame, and the number of QP solves."""
        import mink
        import mujoco

        configuration, data = self.configuration, self.configuration.data
        dt = self.model.opt.timestep
        site = {n: self.model.site(n).id for n in self.names}
        out = np.zeros((frame_count, self.model.nq))
        solves = 0
        target, quat = np.zeros(7), np.zeros(4)
        for t in range(frame_count):
            for tasks in self.stages:
                for task, name, _ in tasks:
                    if name in rotations:
                        target[:4] = rotations[name][t]
                    else:  # position only: keep the frame's current turn, so the twist error is its displacement
                        mujoco.mju_mat2Quat(quat, data.site_xmat[site[name]])
                        target[:4] = quat
                    target[4:] = positions[name][t]
                    task.set_target(mink.SE3(wxyz_xyz=target.copy()))
            for tasks in self.stages:
                error = _stage_error(configuration, tasks)
                for _ in range(1 + MAX_ITERATIONS):
                    velocity = mink.solve_ik(
                        configuration, [task for task, _, _ in tasks], dt, SOLVER, damping=DAMPING, limits=self.limits
                    )
                    configuration.integrate_inplace(velocity, dt)
                    solves += 1
                    new_error = _stage_error(configuration, tasks)
                    if error - new_error <= MIN_ERROR_DROP:
                        break
                    error = new_error
            out[t] = data.qpos
        return out, solves

    def position_error(self, q: np.ndarray, positions: dict[str, np.ndarray]) -> float:
        """Mean distance (m) of the tasked landmarks from their targets (planar base: over the floor)."""
        import mujoco

        data = mujoco.MjData(self.model)
        ids = [self.model.site(n).id for n in self.names]
        mask = np.array([self.position_mask[n] for n in self.names])
        goal = np.stack([positions[n] for n in self.names], axis=1)
        errors = []
        for t, qt in enumerate(q):
            data.qpos[:] = qt
            mujoco.mj_kinematics(self.model, data)
            errors.append(np.linalg.norm((data.site_xpos[ids] - goal[t]) * mask, axis=-1))
        return float(np.mean(errors))


def _stage_error(configuration, tasks) -> float:
    return float(np.linalg.norm(np.concatenate([task.compute_error(configuration) * m for task, _, m in tasks])))


def mink_throughput(source: MotionClip, robot: str, hands: str = "none") -> dict:
    """Frames per second of the mink peer retargeting a human clip straight onto `robot`.

    Model building is not timed; reading the clip's landmarks, target scaling,
    body frames and the per-frame IK are (as the method's stage times include
    its own reading of the source). The position error is the mean over frames
    and tasked landmarks.
    """
    from importlib.metadata import version

    peer = _Peer(robot, hands, set(landmarks_of(source)))
    start = time.perf_counter()
    src = landmarks_of(source)
    positions, rotations = peer.targets(src)
    q, solves = peer.solve(positions, rotations, source.num_frames)
    seconds = time.perf_counter() - start
    return {
        "robot": robot,
        "hands": hands,
        "peer": "mink",
        "engine": f"mink {version('mink')}, {SOLVER}",
        "frames": source.num_frames,
        "seconds": round(seconds, 4),
        "frames_per_second": round(source.num_frames / seconds, 1),
        "solves_per_frame": round(solves / source.num_frames, 2),
        "tasks": len(peer.names),
        "mean_position_error_m": round(peer.position_error(q, positions), 4),
    }
