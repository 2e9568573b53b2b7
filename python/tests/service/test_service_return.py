"""A job asked when the port has just come back is carried out, not lost (the service reads
every motor again first). Real time: a fault proxy cuts and restores a TCP link to the simulator."""

from __future__ import annotations

import threading
from pathlib import Path

import pytest

from nurimc import Bus
from nurimc.errors import PortLost
from nurimc.service import BusService, Sample

from ..transport.outage import BAUD, cuttable_bus


def test_a_job_asked_right_after_the_return_is_carried_out(tmp_path: Path) -> None:
    with cuttable_bus("tcp", tmp_path, ids=(1,)) as (_sim, proxy):
        bus = Bus.open(proxy.url, BAUD, reconnect=True)
        service = BusService(bus)
        samples: list[Sample] = []
        service.subscribe([1], 5, samples.append)
        try:
            assert service.run(lambda b: b.motor(1).read_state()).id == 1
            proxy.cut()
            with pytest.raises(PortLost):
                while True:  # the loss is seen at the next use of the port
                    service.run(lambda b: b.motor(1).read_state())
            proxy.restore()
            transport = service.outage.transport
            assert transport is not None and transport.wait_up(30), "the port did not come back"
            answer: list[object] = []
            worker = threading.Thread(
                target=lambda: answer.append(service.run(lambda b: b.motor(1).read_state())), daemon=True
            )
            worker.start()
            worker.join(30)
            assert not worker.is_alive(), "the job taken at the return was lost: run() never ended"
            assert answer and getattr(answer[0], "id", None) == 1
            assert samples and samples[-1].state is not None  # every motor read again on the return
        finally:
            service.close()
            bus.close()
