"""The building's MQTT tests: a controller and the server's bridge on the real Mosquitto
(127.0.0.1:1883), each run under a topic prefix of its own, so parallel runs never meet."""

import queue
import uuid

import paho.mqtt.client as mqtt
import pytest

from building.bridge import MqttBridge

HOST, PORT = "127.0.0.1", 1883


@pytest.fixture
def prefix():
    return f"hdtest-{uuid.uuid4().hex[:10]}/building"


@pytest.fixture
def controller(prefix):
    """A building's controller: hears the server's requests, publishes states."""
    heard: queue.Queue = queue.Queue()
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"ctl-{uuid.uuid4().hex}")
    client.on_message = lambda c, u, message: heard.put((message.topic, message.payload))
    client.connect(HOST, PORT)
    client.loop_start()
    subscribed = client.subscribe(f"{prefix}/#", qos=1)
    assert subscribed[0] == mqtt.MQTT_ERR_SUCCESS
    client.heard = heard
    yield client
    for kind in ("lift_requests/ELEV", "door_requests/DOOR-2F"):  # no retained leftovers
        client.publish(f"{prefix}/tiny/{kind}", b"", qos=1, retain=True).wait_for_publish(5)
    client.loop_stop()
    client.disconnect()


@pytest.fixture
def bridge(prefix, controller):
    bridge = MqttBridge(host=HOST, port=PORT, prefix=prefix, client_id=f"hd-{uuid.uuid4().hex}")
    yield bridge
    bridge.close()
