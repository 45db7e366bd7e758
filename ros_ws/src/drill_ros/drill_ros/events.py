"""drill_msgs/OperatorEvent from a Notice (drill_core.event_codes): the one place a code
becomes a message, its kind taken from the code's table entry."""
from builtin_interfaces.msg import Time

from drill_core.event_codes import Notice
from drill_msgs.msg import OperatorEvent


def event_message(notice: Notice, stamp: Time, accepted: bool = True, prefix: str = "") -> OperatorEvent:
    """The event of ``notice`` stamped ``stamp``; ``prefix`` goes before its text."""
    msg = OperatorEvent(kind=notice.kind, code=notice.code, value=float(notice.value),
                        text=prefix + notice.text, accepted=bool(accepted))
    msg.header.stamp = stamp
    return msg
