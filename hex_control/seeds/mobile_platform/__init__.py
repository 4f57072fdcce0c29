"""The two-wheeled mobile platform of seed 004 section 4 under the optimal control at the
energy performance index, against two PIDs. SI units (m, kg, s, rad, V).

model       kinematics and Appell-Gibbs dynamics, Lagrange's form with multipliers, DC drives
path        the path of H: straights, clothoid-arc-clothoid curves (Fig. 7, 10)
control     eq. 19's correcting velocities; the energy-index command (eq. 20-21); two PIDs
simulation  the platform on its path; the figures compared (Fig. 8, 10-11)
case        the documented case of config/mobile_platform/platform.yaml
fair        both controllers tuned by one optimizer, criterion and budget; the law's sweep;
            the seed's conditions (hexctl platform tune, bench mobile_platform_fair)
tuning      the older ITAE tuner (kept for hex_control.control.itae's reference)
study, plots  the comparison's files and figures
"""
