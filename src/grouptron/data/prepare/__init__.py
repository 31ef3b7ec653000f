"""From tables to model inputs: scenes on the 0.4 s grid, samples and their neighbours, live
gaps and glitches repaired, augmentation, time windows."""
