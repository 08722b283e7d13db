"""``python -m tests.golden`` (``make golden``): record the golden runs anew."""

from tests.golden.cases import regenerate

regenerate()
