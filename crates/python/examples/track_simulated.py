"""Tracks the simulated rig frame by frame and prints each tip (world mm): replace the
simulator by your rig, backgrounds and cameras' frames."""

import flexshape

sim = flexshape.Simulator(seed=1)                       # the built-in simulated rig
tracker = flexshape.Tracker(sim.rig, sim.backgrounds())  # your rig and empty-scene images
for n, pose in enumerate(sim.motion(10, rate_hz=120)):
    images = sim.render(n, pose).images                  # your cameras' RGB frames
    record = tracker.process(images)
    print(n, record.status, record.tip)
