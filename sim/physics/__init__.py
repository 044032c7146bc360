"""The simulated world: motion limits, battery, the downward sensor and the local frame."""
