"""Files and storage layouts, numpy only: pose layouts, TUM/KITTI trajectories, g2o graphs.

``poses`` converts between ``(..., 4, 4)`` matrices and flat layouts with the quaternion order
named (``xyz_qxyzw``...); ``trajectory`` reads and writes TUM and KITTI files; ``g2o`` reads and
writes 3-D g2o pose graphs and ``g2o2d`` 2-D ones, with their information semantics explicit.
Nothing here imports liebridge's GTSAM layer (``G2OGraph.to_gtsam`` imports the ``gtsam``
package itself, lazily).
"""

from . import g2o, g2o2d, poses, trajectory

__all__ = ["g2o", "g2o2d", "poses", "trajectory"]
