"""The probe's serial link on the host: protocol, port, the operations run over it."""
