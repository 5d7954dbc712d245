"""Controller design: discrete LQR with Bryson weights, and the balancing robots' firmware profiles.

Pure numerics; the plant models the designs start from are linearised in :mod:`sim.physics.sagittal`.
"""

from control.design.balance_profile import BalanceProfile as BalanceProfile
from control.design.balance_profile import is_balancing as is_balancing
from control.design.balance_profile import load_balance_profile as load_balance_profile
from control.design.lqr import check_closed_loop as check_closed_loop
from control.design.lqr import lqr_gains as lqr_gains
