"""Translation of tangents, covariances, information matrices and Jacobians between conventions."""
