"""The model library: the world around the probe and the probe's sensor errors, in float
(world -> sensors); the emulator and the diagnosis both simulate with it."""
