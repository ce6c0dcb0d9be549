"""What the residual holds: the sensor noise model and the residual tests."""
