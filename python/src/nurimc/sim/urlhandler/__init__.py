"""pyserial URL handlers: `sim://` (importing nurimc.sim registers this package)."""
