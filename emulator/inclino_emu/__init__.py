"""inclino_emu: the hardware-in-the-loop emulator of the inclinometer probe.

World (turntable, gravity, Earth field, temperature) -> sensor truth and
error effects -> register-level sensor models on SPI -> the firmware C."""
