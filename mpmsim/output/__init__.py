"""Output: VTU time series with a ParaView .pvd collection, CSV history (rows appended as
recorded, units in a JSON sidecar). Files are written whole (temporary name, then rename) or
not at all; the history CSV grows by whole lines."""
