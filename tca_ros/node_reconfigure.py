"""The node's parameter changes: checked against the schema, then applied live.

A mixin of tca_ros.node.TcaSimNode. A request is refused with one line (field, value,
reason) when the schema, a cross-parameter rule or the model refuses it, and never
raises; an accepted change of the TCA rebuilds the simulator at the node's load and
temperature, a change of the physics step keeps the state (docs/node.md).
"""
import math

import numpy as np
from rcl_interfaces.msg import SetParametersResult

from tca_ros.model.dynamics import StabilityError
from tca_ros.model.params import from_flat_dict, ParameterError, SCHEMA, SPECS
from tca_ros.model.rigs import start_load
from tca_ros.node_clock import WARN_PERIOD
from tca_ros.node_outputs import non_finite
from tca_ros.node_params import build_simulator, check_unknown_overrides, descriptor, \
    GuardedParameterService, NAMESPACED, namespaced_name, NODE_SCHEMA, NODE_SPECS, \
    numbers_as_declared_types, physics_dt, READ_ONLY, REBUILD, validate_node_values
from tca_ros.node_tables import muscle_temperatures, table_rows


class ParametersMixin:
    """Parameter requests of TcaSimNode: validate, apply, never raise."""

    def _declare_parameters(self):
        """Declare the schema's and the node's parameters; build the simulator from them.

        Sets ``_params`` (TcaParams), ``_cfg`` (node settings) and ``_sim``; a bad
        start-up value raises ParameterError with the schema's one-line message.
        """
        self._parameter_service = GuardedParameterService(self)
        all_specs = [(s, s.name in READ_ONLY) for s in SCHEMA + NODE_SCHEMA]
        for spec, _ in all_specs:
            default = spec.default if spec.name not in NAMESPACED else \
                namespaced_name(self.get_namespace(), spec.default)
            self.declare_parameter(spec.name, default, descriptor(spec, with_range=False))
        check_unknown_overrides(self)  # a misspelt name is refused, as tca_sim does
        tca_values = {s.name: self.get_parameter(s.name).value for s in SCHEMA}
        node_values = {s.name: self.get_parameter(s.name).value for s in NODE_SCHEMA}
        self._params = from_flat_dict(tca_values, source='ros parameters')
        self._cfg = validate_node_values(node_values)
        self._sim = build_simulator(self._params, self._cfg)
        # 1000.0 from a params file is stored as the INTEGER it names, 25 for a DOUBLE
        # as 25.0: every parameter keeps its declared type.
        self.set_parameters(numbers_as_declared_types(
            [self.get_parameter(spec.name) for spec, _ in all_specs]))
        # Ranges only now: a bad start-up value gets the schema's one-line message above.
        for spec, read_only in all_specs:
            self.set_descriptor(spec.name, descriptor(spec, read_only))
        self.add_pre_set_parameters_callback(numbers_as_declared_types)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _on_set_parameters(self, parameters):
        """Check new values against the schema and cross-parameter rules; apply them.

        Never raises: an unexpected error refuses the request with its reason.
        """
        owned = [p for p in parameters if p.name in SPECS or p.name in NODE_SPECS]
        if not owned:
            return SetParametersResult(successful=True)
        try:
            return self._apply_parameters(owned)
        except Exception as exc:  # noqa: B902  a parameter request must never end the node
            reason = f'{type(exc).__name__}: {exc}'.splitlines()[0]
            self.get_logger().error(f'parameter change refused: {reason}',
                                    throttle_duration_sec=WARN_PERIOD)
            return SetParametersResult(successful=False, reason=reason)

    def _apply_parameters(self, owned):
        """Validate and apply owned parameters; return the SetParametersResult."""
        tca_values = {s.name: self.get_parameter(s.name).value for s in SCHEMA}
        node_values = dict(self._cfg)
        for p in owned:
            (tca_values if p.name in SPECS else node_values)[p.name] = p.value
        if not self._owns_time:
            self._catch_up()  # up to now with the old values
        cfg = self._cfg
        try:
            params = from_flat_dict(tca_values, source='ros parameters')
            cfg = validate_node_values(node_values)
            rebuild = params != self._params or any(cfg[k] != self._cfg[k] for k in REBUILD)
            if rebuild and params == self._params:
                # same TCA, new step: keep the whole state (set_dt keeps the old on failure)
                self._sim.set_dt(physics_dt(cfg))
            elif rebuild:
                sim = build_simulator(params, cfg, changed=[p.name for p in owned])
                temperature = self._start_temperature()
                load = self._load if params.rig == self._params.rig else start_load(params)
                try:  # the node's load and temperature, not the file's: refuse if no state
                    sim.reset(load=load, temperature=temperature)
                    if non_finite(sim.state):
                        raise ValueError(f'{non_finite(sim.state)} is not finite')
                except (ValueError, ArithmeticError) as exc:
                    raise ParameterError(
                        f'{str(exc).splitlines()[0]} (at the applied load {load:g} N, '
                        f'{temperature if temperature is not None else "ambient"} degC)') \
                        from None
        except StabilityError as exc:
            return SetParametersResult(
                successful=False, reason=f'{exc} (physics_rate = {cfg["physics_rate"]:g} Hz)')
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        old_cfg, self._cfg = self._cfg, cfg
        if rebuild:
            if params != self._params:
                self._params, self._sim, self._load = params, sim, load
                self._reset_sim(temperature)
                self._rows.stop()
                self._rows = table_rows(params)
                self._rows.start(muscle_temperatures(self._sim))
                self._warm_up_shape()
            self._t0_ns, self._steps_done = None, 0
        if cfg['noise.seed'] != old_cfg['noise.seed']:
            self._rng = np.random.default_rng(int(cfg['noise.seed']))
        if not cfg['lockstep']:
            self._awaiting_command = False
        if any(cfg[k] != old_cfg[k] for k in ('publish_rate', 'real_time_factor', 'lockstep')):
            self._make_timer()
        return SetParametersResult(successful=True)

    def _start_temperature(self):
        """Return the temperature (degC) a rebuilt simulator starts at (None: ambient)."""
        temp = self._sim.state.temperature
        return temp if self._failure is None and math.isfinite(temp) else None
