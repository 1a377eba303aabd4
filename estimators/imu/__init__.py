"""IMU pipeline of paper 001 (spec §5.7): wavelet denoising, motion-state recognition, quaternion attitude UKF,
the ``imu-ukf`` estimator, and the (improved) Harris-hawks tuner.

Submodules are imported lazily by their users; importing this package stays cheap (no scikit-learn import).
"""

__all__ = ["attitude_ukf", "denoise", "estimator", "hho", "motion_state", "runs", "synthetic"]
