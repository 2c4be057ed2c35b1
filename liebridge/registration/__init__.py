"""Point-cloud registration into pose graphs: residuals, Jacobians, information, any convention.

``T = T_target_source`` throughout (``q ≈ T·p`` maps a source point into the target frame). The
Jacobians are over any SE(3) convention's tangent of ``T``; :func:`information` is the
Gauss–Newton Hessian at the alignment divided by ``σ²``, as a :class:`RegistrationPose` (an
:class:`~liebridge.uncertain.UncertainPose`); :func:`from_open3d`, :func:`from_small_gicp` and
:func:`from_kiss_icp` read the libraries' own results (presets ``open3d``, ``small_gicp``,
``kiss_icp``, ``hdl_graph_slam`` in :mod:`liebridge.conventions`). GTSAM factors:
:func:`liebridge.gtsam.registration_factor`; g2o edges: :func:`g2o_edge`. numpy only.

>>> import numpy as np
>>> from liebridge import registration as reg
>>> rng = np.random.default_rng(0)
>>> p = rng.normal(size=(100, 3)); q = p + 0.01 * rng.normal(size=(100, 3))
>>> est = reg.information(np.eye(4), p, q, convention="gtsam")
>>> est.sigma_source, est.cov.shape
('residual', (6, 6))
"""

from .g2o import g2o_edge
from .information import RegistrationPose, information, nees_scale, unobservable_directions
from .readers import from_kiss_icp, from_open3d, from_small_gicp
from .residuals import gicp, point_to_plane, point_to_point

__all__ = [
    "RegistrationPose",
    "from_kiss_icp",
    "from_open3d",
    "from_small_gicp",
    "g2o_edge",
    "gicp",
    "information",
    "nees_scale",
    "point_to_plane",
    "point_to_point",
    "unobservable_directions",
]
