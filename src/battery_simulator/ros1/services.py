"""The services and live settings of one BatterySimServer (ros1/action_server.py): set_load, set_charging,
set_state, reset, inject_fault, predict and dynamic_reconfigure. Each change acts on the battery through the
server's ``service_change()`` (its lock; the reply waits until battery_state_pub has sent the change), and a
refusal replies success false with core/battery.py's reason.

:Services (under the robot's namespace):
  - ``battery_simulator/set_load`` (battery_simulator/SetLoad): named payload loads
  - ``battery_simulator/set_charging`` (std_srvs/SetBool): as a charger contact change
  - ``battery_simulator/set_state`` (battery_simulator/SetState): percentage, temperature, health, gauge error
  - ``battery_simulator/reset`` (std_srvs/Trigger): back to the start-up state, mode kept
  - ``battery_simulator/inject_fault`` (battery_simulator/InjectFault): core/status_codes.py FAULTS
  - ``battery_simulator/predict`` (battery_simulator/Predict): what a plan of loads (and a charge after it) would
    do, from a copy of the model (core/prediction.py), computed in the process's prediction workers
    (prediction_service.py); changes nothing, so it replies once computed
"""
import rospy
from dynamic_reconfigure.server import Server as ReconfigureServer
from std_srvs.srv import SetBool, SetBoolResponse, Trigger, TriggerResponse

from battery_simulator.cfg import BatterySimConfig
from battery_simulator.core import ros_names
from battery_simulator.core.battery import MOTION_LOAD, BatteryError
from battery_simulator.core.server_log import charger_reply
from battery_simulator.ros1 import prediction_service
from battery_simulator.srv import InjectFault, InjectFaultResponse, SetLoad, SetLoadResponse, SetState, SetStateResponse


class BatteryServices:
    """The services of ``server`` (a BatterySimServer) under ``namespace``; dynamic_reconfigure at
    ``node_name``."""

    def __init__(self, server, namespace, node_name, log):
        self._server = server
        self.battery = server.battery
        self._log = log
        self._ns = namespace
        self._node_name = node_name
        self._reconfigure = None
        self._services = [
            rospy.Service(namespace + ros_names.SET_LOAD, SetLoad, self._set_load),
            rospy.Service(namespace + ros_names.SET_CHARGING, SetBool, self._set_charging),
            rospy.Service(namespace + ros_names.SET_STATE, SetState, self._set_state),
            rospy.Service(namespace + ros_names.RESET, Trigger, self._reset),
            rospy.Service(namespace + ros_names.INJECT_FAULT, InjectFault, self._inject_fault),
            prediction_service.advertise(namespace + ros_names.PREDICT, self._predict),
        ]

    def start_live_settings(self):
        """dynamic_reconfigure (its first callback waits for an update: the worker must run)."""
        self._reconfigure = _LiveSettings(self.battery.live_values(), self._reconfigure_callback,
                                          namespace=self._node_name + '/')

    def _set_charging(self, request):
        with self._server.service_change():
            self._server.change_contact(bool(request.data), 'set_charging')
        return SetBoolResponse(success=True, message=charger_reply(bool(request.data)))

    def _service(self, response_class, change):
        """Run a service's ``change()`` (its reply's text) as a published change; a refusal replies
        success false with the battery's reason."""
        try:
            with self._server.service_change():
                message = change()
        except BatteryError as error:
            return response_class(success=False, message=str(error))
        return response_class(success=True, message=message)

    def _set_load(self, request):
        return self._service(SetLoadResponse, lambda: self.battery.set_load(request.name, request.power_w))

    def _set_state(self, request):
        return self._service(SetStateResponse, lambda: self.battery.set_state(
            request.percentage, request.temperature_c, request.state_of_health, request.gauge_error))

    def _reset(self, request):
        return self._service(TriggerResponse, self.battery.reset)

    def _inject_fault(self, request):
        return self._service(InjectFaultResponse, lambda: self.battery.inject_fault(request.fault, request.active))

    def _predict(self, request):
        """What the request's plan would do, from a copy of the model taken under the lock, computed in the
        process's prediction workers (prediction_service.py): the copy is brought to now at its present
        loads, and the plan's motion takes the place of cmd_vel's. Changes nothing."""
        model, behind_s = self.battery.model_for_prediction_pickled()
        return prediction_service.answer(self._ns, request, model, behind_s, dropped_loads=(MOTION_LOAD,))

    def _reconfigure_callback(self, config, level):
        """Apply live changes, validated like the start-up values: a refused value is logged and the old one kept.

        The .cfg gives no bounds, so dynamic_reconfigure clamps nothing before this check.
        """
        with self._server.service_change():   # the time so far at the old settings (and time_scale)
            in_force = self.battery.live_values()
            for name, value in in_force.items():
                if config[name] != value:
                    try:
                        self.battery.set_live(name, config[name])
                    except BatteryError as error:
                        self._log.error('dynamic_reconfigure: %s', error)
            config.update(self.battery.live_values())
        return config


class _LiveSettings(ReconfigureServer):
    """dynamic_reconfigure's server, starting from the values in force rather than from the parameter
    server (which would impose the .cfg defaults, and cost 14 master calls a robot in a fleet host)."""

    def __init__(self, values, callback, namespace):
        self._values_in_force = values
        super().__init__(BatterySimConfig, callback, namespace=namespace)

    def _copy_from_parameter_server(self):
        self.config.update(self._values_in_force)
