"""The lossy network model (robotsim.network): what reaches the server, what comes back."""

import random
import threading

import pytest

from robotsim.client import TransportError
from robotsim.network import LossyTransport, NetworkModel


class Recorder:
    """A transport that answers 200 and remembers what it was sent."""

    def __init__(self):
        self.sent = []
        self.arrived = threading.Event()

    def post(self, url, body, headers):
        self.sent.append(body)
        self.arrived.set()
        return 200, {"messages": []}


def lossy(model, *, connected=lambda: True, seed=1):
    server, copies = Recorder(), Recorder()
    transport = LossyTransport(
        model, rng=random.Random(seed), connected=connected, inner=server, duplicates_via=copies
    )
    return transport, server, copies


def test_it_fails_at_once_without_a_network():
    transport, server, _ = lossy(NetworkModel(), connected=lambda: False)

    with pytest.raises(TransportError, match="no network"):
        transport.post("http://server/", {"seq": 1}, {})

    assert server.sent == []
    assert transport.stats.offline == 1


def test_a_lost_request_never_reaches_the_server():
    transport, server, _ = lossy(NetworkModel(request_loss=0.999))

    with pytest.raises(TransportError, match="request lost"):
        transport.post("http://server/", {"seq": 1}, {})

    assert server.sent == []


def test_a_lost_response_was_applied_but_the_robot_cannot_know():
    transport, server, _ = lossy(NetworkModel(response_loss=0.999))

    with pytest.raises(TransportError, match="response lost"):
        transport.post("http://server/", {"seq": 1}, {})

    assert server.sent == [{"seq": 1}]


def test_a_duplicate_arrives_again_later():
    model = NetworkModel(duplicate=0.999, duplicate_delay=(0.05, 0.1))
    transport, server, copies = lossy(model)

    assert transport.post("http://server/", {"seq": 7}, {}) == (200, {"messages": []})

    assert copies.arrived.wait(timeout=5)
    transport.close()
    assert server.sent == copies.sent == [{"seq": 7}]


def test_the_same_seed_loses_the_same_heartbeats():
    def outcomes(seed):
        transport, _, _ = lossy(NetworkModel(request_loss=0.3, response_loss=0.3), seed=seed)
        results = []
        for seq in range(50):
            try:
                transport.post("http://server/", {"seq": seq}, {})
                results.append("ok")
            except TransportError as lost:
                results.append(str(lost))
        return results

    assert outcomes(3) == outcomes(3)
    assert len(set(outcomes(3))) == 3


@pytest.mark.parametrize(
    "fields", [{"request_loss": 1.0}, {"duplicate": -0.1}, {"delay": (0.2, 0.1)}]
)
def test_it_refuses_impossible_models(fields):
    with pytest.raises(ValueError, match="must be"):
        NetworkModel(**fields)
