"""The Fast DDS settings of a fleet host's process (ROS 2): the profile in force, with what thousands of endpoints in
one DDS participant need added, set before rclpy starts its participant.

A fleet host of N robots holds 27 DDS endpoints a robot in one participant (its readers and writers: 9 services of
2, ``cmd_vel``, ``charger_contact``, 7 topics). Fast DDS matches each new endpoint against every endpoint of its own
participant, copying each one's description (EDP::pairing_*_with_any_local_*: ReaderProxyData and WriterProxyData
copies were the top of a perf profile): creating N robots costs N squared. Measured here with 300 robots' endpoints:
22.4 s of CPU, 1.6 s with ``fastdds.ignore_local_endpoints`` (100, 200, 300 robots: 0.4, 1.0, 1.6 s). The robots of
a host never talk to each other through DDS, so nothing is lost: other processes match the host's endpoints as
before. And each endpoint allocates its history as it is used (Fast DDS preallocates a reader's or writer's whole
history: with one sample allocated, 300 robots' endpoints 227 MB instead of 412 MB; with none, ``allocated_samples``
0, a robot costs 20 KB less again, 545 KB against 525 KB in a bare script, 220 against 216 MB for a fleet of 250:
most of a robot's endpoints, its services' readers and writers, ``cmd_vel``, ``charger_contact``, never carry a
sample, and the others allocate theirs at the first one).

What is left, about 18 KB a live endpoint, is not in any setting Fast DDS 3.2 reads from XML (docs/performance.md has
the measured split): each reader's SampleInfo pool (32, ``reader_resource_limits``, not in its XML schema), the
discovery descriptions the participant keeps of its own endpoints and announces, the DDS and RTPS objects and a DDS
Topic per endpoint (every robot's names are distinct), and glibc's bookkeeping of about 117 blocks an endpoint.

Nothing of a user's is written over: the profile in force (``FASTDDS_DEFAULT_PROFILES_FILE``, else
``DEFAULT_FASTDDS_PROFILES.xml`` in the working directory, as Fast DDS looks for it) is read, and a copy with these
additions goes to a private temporary directory; without any, a profile holding only them (Fast DDS's defaults and
the ROS environment, ROS_DISCOVERY_SERVER included, apply as before).
"""
import contextlib
import os
import tempfile
import xml.etree.ElementTree as ElementTree

from battery_simulator.ros2.startup import at_end

PROFILES_VARIABLE = 'FASTDDS_DEFAULT_PROFILES_FILE'
DEFAULT_PROFILES_NAME = 'DEFAULT_FASTDDS_PROFILES.xml'
NAMESPACE = 'http://www.eprosima.com'
#: the participant properties of a fleet host: no matching among its own endpoints (see the module's docstring)
FLEET_PROPERTIES = {'fastdds.ignore_local_endpoints': 'true'}
#: default reader and writer profiles (unless the profile in force has its own): the history allocated as used,
#: nothing before an endpoint's first sample
LEAN_ENDPOINTS = """<profiles xmlns="%s">
  <data_reader profile_name="battery_fleet_reader" is_default_profile="true"><topic><resourceLimitsQos>
    <allocated_samples>0</allocated_samples></resourceLimitsQos></topic>
    <historyMemoryPolicy>DYNAMIC</historyMemoryPolicy></data_reader>
  <data_writer profile_name="battery_fleet_writer" is_default_profile="true"><topic><resourceLimitsQos>
    <allocated_samples>0</allocated_samples></resourceLimitsQos></topic>
    <historyMemoryPolicy>DYNAMIC</historyMemoryPolicy></data_writer>
</profiles>""" % NAMESPACE


def _tag(element):
    return element.tag.rsplit('}', 1)[-1]


def _new_child(parent, name):
    """A new child ``name`` of ``parent`` (in ``parent``'s XML namespace)."""
    return ElementTree.SubElement(parent, parent.tag[:-len(_tag(parent))] + name)


def _child(parent, name):
    """``parent``'s child ``name``, made when missing."""
    found = next((element for element in parent if _tag(element) == name), None)
    return _new_child(parent, name) if found is None else found


def _is_default(element):
    return element.get('is_default_profile', '').strip().lower() == 'true'


def fleet_profile_text(text=None):
    """The XML of the profile ``text`` (None: none in force) with FLEET_PROPERTIES on its default participant
    (one made when it has none) and LEAN_ENDPOINTS' reader and writer defaults where it has none of its own."""
    ElementTree.register_namespace('', NAMESPACE)
    root = ElementTree.fromstring(text) if text else ElementTree.fromstring('<profiles xmlns="%s"/>' % NAMESPACE)
    profiles = root if _tag(root) == 'profiles' else _child(root, 'profiles')
    participant = next((e for e in profiles if _tag(e) == 'participant' and _is_default(e)), None)
    if participant is None:
        participant = _new_child(profiles, 'participant')
        participant.set('profile_name', 'battery_fleet_participant')
        participant.set('is_default_profile', 'true')
    properties = _child(_child(_child(participant, 'rtps'), 'propertiesPolicy'), 'properties')
    for name, value in FLEET_PROPERTIES.items():
        for existing in [p for p in properties if _tag(p) == 'property' and
                         (_child(p, 'name').text or '').strip() == name]:
            properties.remove(existing)
        prop = _new_child(properties, 'property')
        _new_child(prop, 'name').text = name
        _new_child(prop, 'value').text = value
    for lean in ElementTree.fromstring(LEAN_ENDPOINTS):
        if not any(_tag(e) == _tag(lean) and _is_default(e) for e in profiles):
            profiles.append(lean)
    return ElementTree.tostring(root, encoding='unicode')


def profile_in_force(environ=None, cwd=None):
    """The path of the Fast DDS profile a participant of this process would load, or None."""
    environ = os.environ if environ is None else environ
    path = environ.get(PROFILES_VARIABLE)
    if path:
        return path
    local = os.path.join(cwd or os.getcwd(), DEFAULT_PROFILES_NAME)
    return local if os.path.isfile(local) else None


def use_fleet_profile(environ=None):
    """Point this process's Fast DDS at the fleet profile (before rclpy.init): the path written (remove it with
    ``forget_profile`` once the participant exists). A profile in force that cannot be read as XML is left as it is
    (None): Fast DDS then says what is wrong with it."""
    environ = os.environ if environ is None else environ
    if environ.get('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp') not in ('rmw_fastrtps_cpp', 'rmw_fastrtps_dynamic_cpp'):
        return None
    source = profile_in_force(environ)
    try:
        text = None
        if source is not None:
            with open(source, encoding='utf-8') as stream:
                text = stream.read()
        profile = fleet_profile_text(text)
    except (OSError, ElementTree.ParseError):
        return None
    path = os.path.join(tempfile.mkdtemp(prefix='battery_fleet_dds_'), 'fastdds_fleet.xml')
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write(profile)
    environ[PROFILES_VARIABLE] = path
    return path


@contextlib.contextmanager
def fleet_profile():
    """Around rclpy.init and the host's node (its participant): the fleet profile in force inside, removed after,
    also when the process ends inside (a bad --ros-args ends it in rclpy.init through end_process, which runs no
    finally block: the copy was left in the temporary directory)."""
    path = use_fleet_profile()
    at_end(lambda: forget_profile(path))
    try:
        yield path
    finally:
        forget_profile(path)


def forget_profile(path):
    """Remove what ``use_fleet_profile`` wrote (Fast DDS read it when the process's participant was made)."""
    if path is not None:
        with contextlib.suppress(OSError):
            os.remove(path)
            os.rmdir(os.path.dirname(path))
