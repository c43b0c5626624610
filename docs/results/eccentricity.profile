# The standard manoeuvre, then 0.6 s at constant speed (0.6 rad/s at the surface, 300 rad/s at the
# motor: 28 motor turns), for eccentricity: its current ripple is periodic in the rotor angle and
# needs many turns at a steady speed to stand above the noise (docs/model.md, "Eccentricity").
hold 0 0
hold 0.01 0.05
hold 0.15 -0.05
ramp 0.30 -0.05 0.2
sine 0.60 0.01 0.01 4
ramp 0.85 0.01 0.6
end 1.45
