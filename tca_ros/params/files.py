"""Params files: a TCA's parameters read from and written to ROS params-file YAML.

A params file has the ROS 2 layout::

    /**/tca:
      ros__parameters:
        fiber:
          radius: 0.00021
        ...

Values missing from a file take the schema default (the paper's free-stroke TCA);
tca_ros.model.tca_params validates them and builds the TcaParams. The same files
are the node's ``--params-file``.
"""
import yaml

from tca_ros.model.params_schema import NODE_NAME, ParameterError
from tca_ros.model.tca_params import from_flat_dict, to_flat_dict
from tca_ros.params.config_search import resolve_config


def flatten(tree, prefix=''):
    """Flatten nested dicts to dotted names, as rclpy does for params files."""
    out = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, dict):
            out.update(flatten(value, name + '.'))
        else:
            out[name] = value
    return out


def ros_parameters(document, path='<yaml>'):
    """Return the flat ``ros__parameters`` of the ``tca`` node in a params-file document."""
    if not isinstance(document, dict):
        raise ParameterError(f'{path}: not a ROS params file (top level must be a mapping)')
    for node_key, body in document.items():
        name = str(node_key).rstrip('/').rsplit('/', 1)[-1]
        if name in (NODE_NAME, '**', '*') and isinstance(body, dict) \
                and 'ros__parameters' in body:
            return flatten(body['ros__parameters'] or {})
    raise ParameterError(
        f"{path}: no '/**/tca: ros__parameters:' section (ROS 2 params-file layout)")


def load_params(name_or_path, **overrides):
    """Load and validate a params file (path or shipped name); apply dotted overrides."""
    path = resolve_config(name_or_path)
    try:
        with open(path, encoding='utf-8') as fh:
            document = yaml.safe_load(fh)
    except yaml.YAMLError as exc:
        raise ParameterError(f'{path}: invalid YAML ({str(exc).splitlines()[0]})') from None
    values = ros_parameters(document, path)
    values.update({k.replace('__', '.'): v for k, v in overrides.items()})
    try:
        return from_flat_dict(values, source=path)
    except ParameterError as exc:
        raise ParameterError(f'{path}: {exc}') from None


def dump_params(params, path, header=''):
    """Write ``params`` as a ROS params file readable by the node and the CLI."""
    tree = {}
    for name, value in to_flat_dict(params).items():
        node = tree
        *heads, leaf = name.split('.')
        for h in heads:
            node = node.setdefault(h, {})
        node[leaf] = value
    text = yaml.safe_dump({f'/**/{NODE_NAME}': {'ros__parameters': tree}},
                          sort_keys=False, default_flow_style=None)
    with open(path, 'w', encoding='utf-8') as fh:
        if header:
            fh.write(''.join(f'# {line}\n' for line in header.splitlines()))
        fh.write(text)
