"""Host side of the real-robot backend: wire protocol, serial link, camera sources, hardware env."""
