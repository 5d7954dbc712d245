"""State estimation: the inverse of the sensor models (wheel odometry, gyro, delayed pose fixes).

Pure numerics; the simulator feeds :class:`PoseEstimator` its sensor readings each control
period and hands the estimate, not the true pose, to the tracker.
"""

from control.estimation.consistency import chi2_interval as chi2_interval
from control.estimation.consistency import chi2_upper as chi2_upper
from control.estimation.consistency import nees as nees
from control.estimation.consistency import pose_error as pose_error
from control.estimation.ekf import HEADING_SOURCES as HEADING_SOURCES
from control.estimation.ekf import N_STATE as N_STATE
from control.estimation.ekf import STATE_NAMES as STATE_NAMES
from control.estimation.ekf import EstimatorConfig as EstimatorConfig
from control.estimation.ekf import EstimatorDivergedError as EstimatorDivergedError
from control.estimation.ekf import EstimatorInputError as EstimatorInputError
from control.estimation.ekf import PoseEstimator as PoseEstimator
from control.estimation.odometry import counts_to_radians as counts_to_radians
from control.estimation.odometry import wheel_to_body as wheel_to_body
