"""GTSAM factors written in any convention, and IMU preintegration."""
