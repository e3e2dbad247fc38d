"""Output: VTU time series with a ParaView .pvd collection, CSV history. Files are written
whole (temporary name, then rename) or not at all."""
