"""Files and storage layouts, numpy only: pose layouts, TUM/KITTI/EuRoC trajectories, g2o graphs.

``poses`` converts between ``(..., 4, 4)`` matrices and flat layouts with the quaternion order
named (``xyz_qxyzw``...); ``trajectory`` reads and writes TUM and KITTI files; ``g2o`` reads and
writes 3-D g2o pose graphs and ``g2o2d`` 2-D ones, with their information semantics explicit;
``trajfile`` reads TUM (header detected), KITTI and EuRoC (``euroc``) fast, with the quaternion
checks of ``sanity``.
Nothing here imports liebridge's GTSAM layer (``G2OGraph.to_gtsam`` imports the ``gtsam``
package itself, lazily).
"""

from . import euroc, g2o, g2o2d, poses, sanity, trajectory, trajfile
from .euroc import read_euroc, write_euroc
from .trajectory import read_kitti, read_tum, write_kitti, write_tum
from .trajfile import read_trajectory, write_trajectory

__all__ = [
    "euroc",
    "g2o",
    "g2o2d",
    "poses",
    "read_euroc",
    "read_kitti",
    "read_trajectory",
    "read_tum",
    "sanity",
    "trajectory",
    "trajfile",
    "write_euroc",
    "write_kitti",
    "write_trajectory",
    "write_tum",
]
