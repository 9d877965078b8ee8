"""Estimator building blocks (accelerometer, gyroscope) that the methods compose."""
