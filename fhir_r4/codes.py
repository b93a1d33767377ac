"""The code systems and identifier systems of our FHIR resources (docs/integrators/fhir.md).

Every URL is under one base of ours; they name things, nothing is served there.
"""

BASE = "https://hospital-delivery.example/fhir"

# Identifier systems: what our codes identify.
TASK_CODE_SYSTEM = f"{BASE}/identifier/task"  # T-0042
STATION_SYSTEM = f"{BASE}/identifier/station"  # a station's code on its site's map
SITE_SYSTEM = f"{BASE}/identifier/site"  # a site's code
ROBOT_SYSTEM = f"{BASE}/identifier/robot"  # a robot's code

# Code systems.
INPUT_SYSTEM = f"{BASE}/CodeSystem/task-input"  # Task.input[].type
OUTPUT_SYSTEM = f"{BASE}/CodeSystem/task-output"  # Task.output[].type
BUSINESS_STATUS_SYSTEM = f"{BASE}/CodeSystem/business-status"  # Task.businessStatus
DEVICE_PROPERTY_SYSTEM = f"{BASE}/CodeSystem/device-property"  # Device.property[].type
ROBOT_STATUS_SYSTEM = f"{BASE}/CodeSystem/robot-status"  # its values (protocol v1 status)
PRESENCE_SYSTEM = f"{BASE}/CodeSystem/robot-presence"

# Task.input types.
PICKUP = "pickup"  # valueReference: a Location (station), one or more
DROPOFF = "dropoff"  # valueReference: a Location (station), one or more
SECURE = "secure"  # valueBoolean: locked in a compartment that opens for the recipient
RECIPIENT = "recipient"  # valueString, or valueReference with a display: who receives it
INPUT_TYPES = (PICKUP, DROPOFF, SECURE, RECIPIENT)

# Task.output types.
PIN = "pin"  # valueString: a secure delivery's PIN, in the answer to its creation only

# HL7's own systems we use.
PHYSICAL_TYPE_SYSTEM = "http://terminology.hl7.org/CodeSystem/location-physical-type"
