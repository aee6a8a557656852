"""The sampled-data simulator: the loop (Python and compiled), the batch of a sweep, the plant's
integration, actuators and encoders, the limits checked before a run, results and their metrics.
"""
