"""Convention descriptors as data, presets for real libraries, and detection."""
