"""rosidl_runtime_py's `message_to_yaml`, which `ros2 topic echo` prints, for the
checks (rosidl_runtime_py has no wheel): its conversion of a message to
ordered data, restated from its rules (`byte`s as one-character strings,
numpy values as Python's, truncation with `...`, `--no-arr`'s and `--no-str`'s
abbreviations), then PyYAML's own `yaml.dump` with the options it passes."""
import sys
from collections import OrderedDict

import yaml
from rosidl_parser import definition as d


def _represent_ordereddict(dumper, data):
    items = [(dumper.represent_data(k), dumper.represent_data(v)) for k, v in data.items()]
    return yaml.nodes.MappingNode("tag:yaml.org,2002:map", items)


yaml.add_representer(OrderedDict, _represent_ordereddict)


def _rosidl_type_name(t):
    if isinstance(t, d.BasicType):
        return t.typename
    if isinstance(t, d.AbstractString):
        return "string"
    if isinstance(t, d.AbstractWString):
        return "wstring"
    if isinstance(t, d.NamespacedType):
        return "/".join(t.namespaced_name())
    return "unknown"


def _abbreviated(value, t):
    inner = _rosidl_type_name(t.value_type)
    if isinstance(t, d.Array):
        return f"<array type: {inner}[{t.size}]>"
    if isinstance(t, d.BoundedSequence):
        return f"<sequence type: {inner}[{t.maximum_size}], length: {len(value)}>"
    return f"<sequence type: {inner}, length: {len(value)}>"


def to_ordereddict(msg, trunc, no_arr, no_str):
    """rosidl_runtime_py.convert.message_to_ordereddict's rules."""
    from collections import OrderedDict
    import array
    import numpy

    def convert(value, t=None):
        if isinstance(value, bytes):
            text = "".join(chr(c) for c in value)
            return text[:trunc] + "..." if trunc is not None and len(value) > trunc else text
        if isinstance(value, str):
            if no_str:
                return f"<string length: <{len(value)}>>"
            return value[:trunc] + "..." if trunc is not None and len(value) > trunc else value
        if isinstance(value, (list, tuple, array.array, numpy.ndarray)):
            if no_arr and t is not None:
                return _abbreviated(value, t)
            if trunc is not None and len(value) > trunc:
                return [convert(v) for v in value[:trunc]] + ["..."]
            return [convert(v) for v in value]
        if isinstance(value, numpy.number):
            return value.item()
        if isinstance(value, (bool, float, int)):
            return value
        return to_ordereddict(value, trunc, no_arr, no_str)

    out = OrderedDict()
    for name, t in zip(msg.get_fields_and_field_types().keys(), msg.SLOT_TYPES):
        out[name] = convert(getattr(msg, name), t)
    return out



def message_to_yaml(msg, truncate_length=None, no_arr=False, no_str=False, flow_style=False):
    """The text rosidl_runtime_py's `message_to_yaml` returns."""
    return yaml.dump(to_ordereddict(msg, truncate_length, no_arr, no_str), allow_unicode=True, width=sys.maxsize,
                     default_flow_style=flow_style)
