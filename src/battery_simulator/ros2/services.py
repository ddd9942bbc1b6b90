"""The ``battery_simulator`` node's services on ROS 2 (ros1/services.py's twin): set_load, set_charging,
set_state, reset, inject_fault and predict (its answers: prediction_service.py).

A change is stepped and handed to the status front before the reply, so the
next ``battery_status`` shows it.
"""
from std_srvs.srv import SetBool, Trigger

from battery_simulator.core import ros_names
from battery_simulator.core.battery import BatteryError
from battery_simulator.core.server_log import charger_reply
from battery_simulator.ros2 import prediction_service
from battery_simulator.srv import InjectFault, SetLoad, SetState


class BatteryServices:
    """One battery's services on ``node`` under ``namespace``; ``server`` is its BatterySimServer."""

    def __init__(self, node, namespace, server):
        self.node, self.server, self.battery = node, server, server.battery
        self._key = node.get_namespace().rstrip('/') + '/' + namespace
        ns = namespace
        node.create_service(SetLoad, ns + ros_names.SET_LOAD, self._set_load)
        node.create_service(SetBool, ns + ros_names.SET_CHARGING, self._set_charging)
        node.create_service(SetState, ns + ros_names.SET_STATE, self._set_state)
        node.create_service(Trigger, ns + ros_names.RESET, self._reset)
        node.create_service(InjectFault, ns + ros_names.INJECT_FAULT, self._inject_fault)
        self._predictions = prediction_service.advertise(node, ns + ros_names.PREDICT, self._key, self.battery)

    def _service(self, response, change):
        """Run ``change()`` (the reply's text) on the battery, publish it, then reply; a refusal replies
        success false with the battery's reason and changes nothing."""
        try:
            self.battery.advance_to_now()
            response.message = change()
            response.success = True
        except BatteryError as error:
            response.success, response.message = False, str(error)
            return response
        self.server.update(publish_now=True)
        return response

    def _set_charging(self, request, response):
        connected = bool(request.data)
        return self._service(response, lambda: self.server.change_contact(connected, 'set_charging') or
                             charger_reply(connected))

    def _set_load(self, request, response):
        return self._service(response, lambda: self.battery.set_load(request.name, request.power_w))

    def _set_state(self, request, response):
        return self._service(response, lambda: self.battery.set_state(
            request.percentage, request.temperature_c, request.state_of_health, request.gauge_error))

    def _reset(self, request, response):
        return self._service(response, self.battery.reset)

    def _inject_fault(self, request, response):
        return self._service(response, lambda: self.battery.inject_fault(request.fault, request.active))

