"""Type stubs of the compiled half of kinechain (the Chain class and the exceptions)."""

import os
from typing import Any, Iterable, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt


__version__: str

class View:
    """A self-contained HTML page of the robot: html, _repr_html_(), save(path)."""
    html: str
    def _repr_html_(self) -> str: ...
    def save(self, path: Union[str, os.PathLike[str]]) -> None: ...

class IkResult:
    """What Chain.ik found: q, success, position_error (m), rotation_error (rad), iterations,
    restarts (one row, or N rows)."""
    q: npt.NDArray[np.float64]
    success: Any
    position_error: Any
    rotation_error: Any
    iterations: Any
    restarts: Any

class Error(ValueError):
    """Any error of kinechain."""

class LoadError(Error):
    """A robot file or text that cannot be loaded; the message names file, line, column, joint."""

class StateError(Error):
    """Joint values that cannot be evaluated (shape, length, not finite, out of limits)."""

class LogError(Error):
    """A joint log that cannot be read (a ROS bag, a dataset); names the file, topic, message."""

class FkResult:
    """What Chain.fk computed: poses (L, 4, 4) or (N, L, 4, 4); with qd omega and v, with qdd
    alpha and a, (L, 3) or (N, L, 3); None where not computed. r[name] is one link's pose."""

    @property
    def links(self) -> list[str]: ...
    @property
    def poses(self) -> npt.NDArray[np.float64]: ...
    @property
    def omega(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def v(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def alpha(self) -> Optional[npt.NDArray[np.float64]]: ...
    @property
    def a(self) -> Optional[npt.NDArray[np.float64]]: ...
    def __getitem__(self, link: str) -> npt.NDArray[np.float64]: ...
    def __len__(self) -> int: ...

class Chain:
    """A robot: links, joints and limits; immutable and shared between threads."""

    @staticmethod
    def from_file(
        path: str,
        floating_base: bool = False,
        couplings: bool = False,
        args: Optional[list[Tuple[str, str]]] = None,
        package_paths: Optional[list[str]] = None,
    ) -> "Chain":
        """Loads a DH table (.yaml, .yml), a URDF file (.urdf) or an MJCF file (.xml); with floating_base, a
        floating joint root_joint between the world and the root link."""
    @staticmethod
    def from_urdf_string(text: str, floating_base: bool = False) -> "Chain":
        """A robot from URDF text."""
    @staticmethod
    def from_mjcf_string(
        text: str, base_dir: Optional[str] = None, floating_base: bool = False, couplings: bool = False
    ) -> "Chain":
        """A robot from MJCF text, its includes looked up in base_dir (default: the current
        directory)."""
    @property
    def keyframes(self) -> dict[str, npt.NDArray[np.float64]]:
        """The file's named configurations (MJCF <key>), each a q of nq entries."""
    @staticmethod
    def from_yaml_string(text: str, floating_base: bool = False) -> "Chain":
        """A robot from DH YAML text."""
    @property
    def name(self) -> str:
        """The robot's name."""
    @property
    def warnings(self) -> list[str]:
        """What the loader noticed without refusing the file (kinechain.load issues each as a UserWarning)."""
    @property
    def dof(self) -> int:
        """Degrees of freedom: entries of qd, qdd and columns of a Jacobian (nv)."""
    @property
    def nq(self) -> int:
        """Entries of q: dof, plus one for a floating joint and for each ball joint (quaternions)."""
    @property
    def nv(self) -> int:
        """Entries of qd and qdd."""
    @property
    def q_names(self) -> list[str]:
        """The name of each entry of q (NAME.theta/NAME.d of a cylindrical joint, NAME.x ...
        NAME.qz of a floating one, NAME.qw ... NAME.qz of a ball joint)."""
    @property
    def q_units(self) -> list[str]:
        """Each entry of q's unit: "rad", "m" or "1" (a quaternion's)."""
    @property
    def v_names(self) -> list[str]:
        """The name of each entry of qd (NAME.vx ... NAME.wz of a floating joint, NAME.wx ... NAME.wz of a ball joint)."""
    @property
    def joint_names(self) -> list[str]:
        """q_names."""
    @property
    def link_names(self) -> list[str]:
        """Every link, in the chain's order."""
    @property
    def joints(self) -> list[dict[str, Any]]:
        """The tree: each joint's name, type, parent and child links, axis, origin and post
        (4 × 4), theta and d at q = 0, its first index in q (or None) and its mimic (or None)."""
    @property
    def parents(self) -> dict[str, Optional[str]]:
        """Each link's parent link (None for the root)."""
    @property
    def lower(self) -> npt.NDArray[np.float64]:
        """Smallest admitted value of each entry of q (-inf where unlimited)."""
    @property
    def upper(self) -> npt.NDArray[np.float64]:
        """Largest admitted value of each entry of q (inf where unlimited)."""
    def neutral(self) -> npt.NDArray[np.float64]:
        """A configuration inside the limits."""
    def fk(
        self,
        q: npt.ArrayLike,
        qd: Optional[npt.ArrayLike] = None,
        qdd: Optional[npt.ArrayLike] = None,
        *,
        links: Optional[Iterable[str]] = None,
        base: Optional[str] = None,
        check_limits: bool = True,
        threads: Optional[int] = None,
        out: Optional[Union[npt.NDArray[np.float64], "FkResult"]] = None,
    ) -> FkResult:
        """Poses (and velocities, accelerations) of the links at q of shape (dof,) or (N, dof);
        out: a C-contiguous float64 array of the poses' shape to write them into, or the result
        of an earlier call on the same links with the same quantities, written again."""
    def poses(
        self,
        q: npt.ArrayLike,
        *,
        links: Optional[Iterable[str]] = None,
        check_limits: bool = True,
        threads: Optional[int] = None,
        out: Optional[npt.NDArray[np.float64]] = None,
    ) -> npt.NDArray[np.float64]:
        """fk(q, links=...).poses in one call: (L, 4, 4) or (N, L, 4, 4)."""
    def pose(
        self,
        q: npt.ArrayLike,
        link: str,
        *,
        check_limits: bool = True,
        threads: Optional[int] = None,
    ) -> npt.NDArray[np.float64]:
        """The pose world_from_link of one link: (4, 4) or (N, 4, 4)."""
    def random(
        self, n: Optional[int] = None, *, seed: int = 0, base: Tuple[float, float] = (-1.0, 1.0)
    ) -> npt.NDArray[np.float64]:
        """Random configurations, (nq,) or (n, nq): uniform within limits, a floating base in
        the box base along each axis, turned by a uniformly random rotation."""
    def to_layout(
        self,
        q: npt.ArrayLike,
        qd: Optional[npt.ArrayLike] = None,
        qdd: Optional[npt.ArrayLike] = None,
        *,
        layout: str,
    ) -> Tuple[npt.NDArray[np.float64], Optional[npt.NDArray[np.float64]], Optional[npt.NDArray[np.float64]]]:
        """(q, qd, qdd) in "pinocchio"'s or "mujoco"'s layout."""
    def from_layout(
        self,
        q: npt.ArrayLike,
        qd: Optional[npt.ArrayLike] = None,
        qdd: Optional[npt.ArrayLike] = None,
        *,
        layout: str,
    ) -> Tuple[npt.NDArray[np.float64], Optional[npt.NDArray[np.float64]], Optional[npt.NDArray[np.float64]]]:
        """kinechain's (q, qd, qdd) from "pinocchio"'s or "mujoco"'s layout."""
    def jacobian(
        self,
        q: npt.ArrayLike,
        link: str,
        *,
        frame: str = "world",
        point: Optional[npt.ArrayLike] = None,
        base: Optional[str] = None,
        check_limits: bool = True,
        threads: Optional[int] = None,
        out: Optional[npt.NDArray[np.float64]] = None,
    ) -> npt.NDArray[np.float64]:
        """Geometric Jacobian of link: (6, dof) or (N, 6, dof), rows v then omega (into out, a
        C-contiguous float64 array of that shape, when given).

        frame="world": v of the link origin (or of point, in link coordinates) and omega in
        world axes; frame="link": both in the link's own axes."""
    def ik(
        self,
        target: Any,
        link: Union[str, Sequence[str]],
        q0: Optional[npt.ArrayLike] = None,
        *,
        base: Any = None,
        point: Any = None,
        weights: Any = None,
        threads: Optional[int] = None,
        seed: int = 0,
        position_tolerance: float = 1e-6,
        rotation_tolerance: float = 1e-6,
        iterations: int = 40,
        max_attempts: int = 100,
        time_limit: Optional[float] = None,
        closest: Optional[str] = None,
        locked: Optional[Sequence[str]] = None,
        start: str = "mid",
    ) -> "IkResult":
        """Joint values that put link (or links) at target: (4, 4) / (N, 4, 4) poses or (3,) /
        (N, 3) positions, in the world or in base's frame; see kinechain._ik.ik."""
    def view(self, q: Optional[npt.ArrayLike] = None, *, times: Optional[npt.ArrayLike] = None) -> "View":
        """The robot at q, or along (N, nq) rows with a timeline, as a self-contained HTML page."""
    def __reduce__(self) -> Tuple[Any, Tuple[str, str]]: ...
    def __eq__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...

def _expand_xacro(
    path: str, args: Optional[list[Tuple[str, str]]] = None, package_paths: Optional[list[str]] = None
) -> str: ...
def _read_joint_states(
    path: str, topic: str, stamp: str, missing: str, velocities: bool, efforts: bool, keep_truncated: bool
) -> Tuple[
    list[str],
    npt.NDArray[np.int64],
    npt.NDArray[np.float64],
    Optional[npt.NDArray[np.float64]],
    Optional[npt.NDArray[np.float64]],
    bool,
]: ...
