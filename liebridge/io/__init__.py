"""Files and storage layouts, numpy only: pose layouts, TUM/KITTI/EuRoC trajectories, g2o graphs.

``poses`` converts between ``(..., 4, 4)`` matrices and flat layouts with the quaternion order
named (``xyz_qxyzw``...); ``trajectory`` holds the one TUM reader and writer and the KITTI ones,
``euroc`` EuRoC's, ``trajfile`` reads any of them by format (``read_trajectory``), each returning
a :class:`Trajectory` (``stamps``, ``T``, ``cov``, ``frame_id``, ``child_frame_id``,
``source``); ``g2o`` reads and writes 3-D g2o pose graphs and ``g2o2d`` 2-D ones, with their
information semantics explicit; ``sanity`` checks quaternions (their storage order, judged by
the direction of travel) and holds the one policy for imperfect real files (repeated stamps,
quaternions off unit: ``repeated_stamps``, ``unit_quaternions``); ``atomic`` is the one safe-write
helper every writer uses (``atomic_write``, ``atomic_path``, ``refuse_same_file``).
Nothing here imports liebridge's GTSAM layer (``G2OGraph.to_gtsam`` imports the ``gtsam``
package itself, lazily).
"""

from . import atomic, euroc, g2o, g2o2d, poses, sanity, trajectory, trajfile
from .atomic import atomic_path, atomic_write, refuse_same_file
from .euroc import read_euroc, write_euroc
from .trajectory import Trajectory, read_kitti, read_tum, write_kitti, write_tum
from .trajfile import read_trajectory, write_trajectory

__all__ = [
    "Trajectory",
    "atomic",
    "atomic_path",
    "atomic_write",
    "euroc",
    "g2o",
    "g2o2d",
    "poses",
    "read_euroc",
    "read_kitti",
    "read_trajectory",
    "read_tum",
    "refuse_same_file",
    "sanity",
    "trajectory",
    "trajfile",
    "write_euroc",
    "write_kitti",
    "write_trajectory",
    "write_tum",
]
