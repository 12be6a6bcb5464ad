"""Mathematics shared by the fits and the bundle's model contract (no devices, no files)."""
