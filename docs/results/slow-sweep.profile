# slow sweep: 10 rad/s at the motor (0.02 rad/s at the surface), both directions
hold 0 0
ramp 0.01 0 0.02
ramp 0.41 0.008 -0.02
end 0.81
