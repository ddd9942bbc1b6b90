"""A level alarm with hysteresis (no rospy): battery_low and battery_critical.

It turns on when the level falls below its threshold and off only when the
level rises above threshold + hysteresis, so a level dithering around the
threshold gives one event, not many.
"""


class LevelAlarm:
    def __init__(self, threshold, hysteresis):
        if not 0.0 <= threshold <= 1.0 or not 0.0 <= hysteresis <= 1.0:
            raise ValueError('threshold %r and hysteresis %r must be fractions in [0, 1]' % (threshold, hysteresis))
        self.threshold = threshold
        self.hysteresis = hysteresis
        self.active = False

    def update(self, level):
        """Feed a level (fraction 0..1); True when the alarm changed state."""
        if not self.active and level < self.threshold:
            self.active = True
            return True
        if self.active and level > self.threshold + self.hysteresis:
            self.active = False
            return True
        return False
