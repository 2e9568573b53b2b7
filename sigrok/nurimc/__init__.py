# SPDX-License-Identifier: GPL-2.0-or-later
# This file is part of nurimc's sigrok protocol decoder (sigrok/nurimc/COPYING).

"""
Nurirobot MC-RS485: the protocol of Nurirobot MC and BLMC-H motor controllers on an RS485
bus (8N1, 110 to 1,000,000 bps). Stack it on the UART decoder: a single half-duplex line
(RX only, e.g. the A/B pair through a receiver or a differential probe) or both sides of a
transceiver (RX and TX). Frames are FF FE, ID, size, checksum, mode, data; the decoder
resynchronises on noise exactly as the nurimc libraries' stream parser does.
"""

from .pd import Decoder as Decoder
