"""Foot-contact thresholds as Blender properties: one table for the Retarget panel's settings and the
Fix Foot Sliding operator's redo panel (foot_contacts.ContactSettings holds the numbers)."""
import bpy
from bpy.props import FloatProperty

from .foot_contacts import ContactSettings

_DEFAULTS = ContactSettings()
# name -> (label, minimum, maximum, unit, description); leg lengths and seconds, as ContactSettings.
_FIELDS = {
    "height_enter": ("Height In", 0.001, 1.0, 'NONE',
                     "A foot point enters a contact this close to its standing height (leg lengths)"),
    "height_leave": ("Height Out", 0.001, 1.0, 'NONE', "...and leaves it higher than this (leg lengths)"),
    "speed_enter": ("Speed In", 0.001, 10.0, 'NONE',
                    "A foot point enters a contact slower than this (leg lengths per second)"),
    "speed_leave": ("Speed Out", 0.001, 10.0, 'NONE',
                    "...and leaves it faster than this (leg lengths per second)"),
    "min_length": ("Shortest", 0.0, 2.0, 'TIME_ABSOLUTE', "Contacts shorter than this are ignored"),
    "blend": ("Blend", 0.001, 2.0, 'TIME_ABSOLUTE', "How long the feet take to ease into and out of a plant"),
}


def properties() -> dict:
    """Annotations for a class that holds the thresholds (an Operator or a PropertyGroup)."""
    return {name: FloatProperty(name=label, default=getattr(_DEFAULTS, name), min=low, max=high, precision=3,
                                unit=unit, description=description)
            for name, (label, low, high, unit, description) in _FIELDS.items()}


def settings(holder) -> ContactSettings:
    """ContactSettings from a holder of properties(); the leave thresholds never below the enter ones."""
    values = {name: getattr(holder, name) for name in _FIELDS}
    values["height_leave"] = max(values["height_leave"], values["height_enter"])
    values["speed_leave"] = max(values["speed_leave"], values["speed_enter"])
    return ContactSettings(**values)


def draw(layout, holder) -> None:
    col = layout.column(align=True)
    for name in _FIELDS:
        col.prop(holder, name)


class MOTIONKIT_PG_contacts(bpy.types.PropertyGroup):
    __annotations__ = properties()


classes = (MOTIONKIT_PG_contacts,)
