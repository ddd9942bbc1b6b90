"""rclpy.init for this package's executables: a ``--ros-args`` that rcl cannot parse (``-p name:=`` with no
value, a remap without ``:=``) is one line naming it and exit status 2, not rclpy's RCLError traceback."""
import re
import sys

EXIT_BAD_ARGUMENTS = 2


def rcl_problem(error):
    """rcl's first sentence ("Couldn't parse parameter override rule: '-p name:='"), without its lexer's
    details and source location."""
    text = re.sub(r',? at /\S+:\d+\s*$', '', str(error).strip()).replace('failed to initialize rcl: ', '')
    return text.split('. Error: ')[0].rstrip('.')


def init_rclpy(prog, args, **options):
    """rclpy.init(args=args, **options); a malformed --ros-args ends the process with one line."""
    import rclpy
    from rclpy.impl.implementation_singleton import rclpy_implementation

    try:
        rclpy.init(args=args, **options)
    except rclpy_implementation.RCLError as error:
        print('%s: bad --ros-args: %s' % (prog, rcl_problem(error)), file=sys.stderr, flush=True)
        sys.exit(EXIT_BAD_ARGUMENTS)
