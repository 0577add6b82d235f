"""How often each of the dog's sensor drivers publishes a sample (Hz)."""

__all__ = ["SENSOR_RATES_HZ"]

SENSOR_RATES_HZ = {
    "range": 20.0,
    "touch": 50.0,
    "imu": 100.0,
    "odometry": 50.0,
    "joints": 25.0,
    "battery": 2.0,
    "beacon": 10.0,
    "motion": 10.0,
}
