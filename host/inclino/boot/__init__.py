"""Bootloader tools: the S-record image, the flash map and the flash-and-verify session."""
