"""The firmware core on the Freescale S08 through SDCC and the ucsim simulator."""
