"""Every command of `nurimc`, by the module that registers it: (name, help, short help, hidden).

Written by scripts/cli_index.py (do not edit): `nurimc --help` lists the commands from here without
importing their modules (docs/performance.md, Start-up)."""

COMMAND_INDEX: dict[str, tuple[tuple[str, str | None, str | None, bool], ...]] = {
    'inspect': (
        ('scan', 'Find every controller across rates and IDs.\n\nExample: nurimc --port /dev/ttyUSB0 scan --rates 9600,115200', None, False),
        ('ping', 'Check that a controller answers, and how fast.\n\nExample: nurimc --port sim://?ids=0,1 --id 1 ping', None, False),
        ('status', 'Position, speed, current, direction and every setting of one controller.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 status --json', None, False),
        ('watch', 'Live table of one or many motors (Ctrl+C to stop).\n\nOn a terminal the table is redrawn; to a file or a pipe, each reading is a line per motor.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1,2,3 watch', None, False),
    ),
    'motion': (
        ('move', 'Move to a position (or by an amount) at a speed or in a time.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 move 90 --rpm 60', None, False),
        ('run', 'Turn at a speed, ramping up.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 run -120 --ramp 1', None, False),
        ('release', 'Control off: the motor is no longer driven and coasts to a stop.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 release', None, False),
        ('stop', 'Slow to a stop and hold there (speed 0, read back, then hold; see docs/cli.md).\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 stop', None, False),
        ('hold', 'Control on, holding the present position.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 hold', None, False),
    ),
    'settings_cmd': (
        ('get', 'Read settings, in physical units (one name, or several: get ratio resolution).\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 get ratio', None, False),
        ('set', 'Write one setting and verify it by reading it back.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 set response-time 300us', None, False),
        ('backup', 'Save every setting of every motor (--id, or all found at --baud) to a file.\n\nExample: nurimc --port /dev/ttyUSB0 backup robot.json', None, False),
        ('restore', 'Write back every setting that differs from a backup (each verified).\n\nExample: nurimc --port /dev/ttyUSB0 restore robot.json', None, False),
        ('factory-reset', 'Erase every setting of one controller: it returns as ID 0 at 9600 bps.\n\nExample: nurimc --port /dev/ttyUSB0 --id 3 factory-reset --yes', None, False),
    ),
    'tune_cmd': (
        ('tune', "Tune the position or speed loop's gains with small steps on the motor.\n\nThe starting gains are read first and written back on Ctrl+C, an error or a lost port;\nthe chosen gains are written with --apply, otherwise after you confirm.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 tune --loop position --goal no-overshoot --travel 20", None, False),
    ),
    'frames': (
        ('decode', "Decode frames: fields in physical units, or what is wrong.\n\nExample: nurimc --product rsa decode FF FE 00 07 76 01 00 46 50 03 E8   (an RSA's frame)", None, False),
        ('encode', 'Build a frame with the right checksum.\n\nExample: nurimc encode position_speed direction=0 position=180deg speed=100rpm --to 0', None, False),
        ('sniff', 'Listen without sending and decode everything on the bus, with timestamps.\n\nExample: nurimc --port /dev/ttyUSB0 --baud 115200 sniff', None, False),
        ('replay', 'Decode a traffic log, or a logic-analyzer capture (docs/sigrok.md).\n\nExample: nurimc replay traffic.log', None, False),
    ),
    'demo': (
        ('demo', 'Simulated bus with three motors: discover them, configure them, move them, watch them.\n\nExample: nurimc demo', None, False),
        ('bench', 'Run the benchmarks (from a source checkout); record their results only with --record.\n\nExample: nurimc bench --record', None, False),
    ),
    'sim_cmd': (
        ('sim', 'Simulated controllers (MC, BLMC-H, RSA, RSAVW, SA, SM) on a simulated RS485 bus, on a pseudo-terminal and/or TCP.\n\nExample: nurimc sim --link /tmp/nurimc0 --ids 1,2 --motor 3@57600 --wire-timing\n\nIn a script or the quick start: nurimc sim --link /tmp/nurimc0 --ids 1,2 --background\n\nMixed product lines, each at its own rate:\nnurimc sim --link /tmp/nurimc0 --motor 1@9600:mc --motor 7@57600:rsa --motor 9@115200:sm', None, False),
    ),
    'dashboard_cmd': (
        ('dashboard', 'Serve the web console: discover, plot, drive, tune, back up; emergency stop.\n\nExample: nurimc --port /dev/ttyUSB0 --baud 115200 dashboard   (then open http://127.0.0.1:8485)', None, False),
    ),
    'ros2_cmd': (
        ('ros2', 'Publish joint_states and /diagnostics; obey position_commands, velocity_commands and estop (ROS 2 over DDS).\n\nExample: nurimc --port /dev/ttyUSB0 --baud 115200 ros2 --ids 1,2 --namespace /arm', None, False),
    ),
    'record_cmd': (
        ('record', 'Record joint_states (sensor_msgs/JointState) and every raw frame with its direction and time.\n\nExample: nurimc --port /dev/ttyUSB0 --baud 115200 record --mcap run.mcap --ids 1,2 --seconds 10', None, False),
        ('repair-mcap', 'Repair a torn MCAP file (a crash mid-write, a copy cut short): keep every whole record, write a complete file.\n\nExample: nurimc repair-mcap run.mcap --out run-fixed.mcap', None, False),
    ),
    'service_cmd': (
        ('serve', 'Hold a port with no interface of its own and share it with other nurimc programs.\n\nThe motors of --id (else those found at --baud) are known to the emergency stop. Other\nprograms on this machine that open the same port attach to this one (`nurimc --port P\nstatus`, `watch`, `record`, `estop`, `clients`).\n\nExample: nurimc --port /dev/ttyUSB0 --baud 115200 serve', None, False),
        ('clients', 'List the programs attached to the holder of --port (program, PID, since, requests, polls).\n\nExample: nurimc --port /dev/ttyUSB0 clients', None, False),
        ('estop', 'Emergency stop: control off to every motor of the bus, read back (exit 0 only when every motor reads off).\n\nThrough the holder of --port if a nurimc program holds it (it knows every motor and latches\nthe stop for every program); else on the port itself: the motors of --id, or those found\nat --baud. Motors that could not be read back are named.\n\nExample: nurimc --port /dev/ttyUSB0 estop', None, False),
    ),
    'recording_cmd': (
        ('inspect', 'Summarise an MCAP recording: topics, message counts, time span, motors.\n\nExample: nurimc inspect run.mcap', None, False),
        ('export', "Write a recording's joint samples as CSV: one row per sample, time in seconds, units in the header.\n\nExample: nurimc export run.mcap --csv run.csv", None, False),
    ),
    'zero_cmd': (
        ('set-zero', 'Make the present position zero (position reset) and verify it by reading the position back.\n\nExample: nurimc --port /dev/ttyUSB0 --id 1 set-zero', None, False),
    ),
}
