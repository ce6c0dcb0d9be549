% control_hand.m -- drive a running `hand-service run` from MATLAB over its TCP control
% API: arm, set a target, start, record, read the status while the finger moves, stop.
%
% Start the daemon with a TCP port (loopback only), for example
%     hand-service run --tcp-port 7000
% then run this script in MATLAB (R2020b or later: tcpclient with readline/writeline;
% jsonencode/jsondecode since R2016b). The protocol is JSON lines (docs/api.md): one
% request per line, one reply per line, {"ok": true, "result": ...} or
% {"ok": false, "error": "..."}. The TCP port serves only a client that shows the token
% the daemon writes, mode 0600, beside its socket: api.sock -> api.token, by default
% $XDG_RUNTIME_DIR/hand-service/api.token or /tmp/hand-service-<uid>/api.token.
% The same steps in Python: docs/examples/python/control_hand.py.

port = 7000;                 % the daemon's --tcp-port
finger = 'index';            % the finger to move (a field name of status.fingers)
angleDeg = 45;               % its target angle, deg
seconds = 3;                 % how long to record
% the recording: a new file in the daemon's recording directory (run --record-dir;
% default ~/.local/share/hand-service/recordings); a path elsewhere is refused
recordPath = fullfile(getenv("HOME"), ".local", "share", "hand-service", "recordings", ...
                      "run-matlab.csv");

tokenFile = defaultTokenFile();
token = strtrim(fileread(tokenFile));

hand = tcpclient("127.0.0.1", port, "Timeout", 5);
configureTerminator(hand, "LF");

% the first request carries the token; later ones on this connection need none
request(hand, struct("cmd", "auth", "token", token));

status = request(hand, struct("cmd", "status"));
fprintf("state %s at t = %.2f s\n", status.state, status.t_s);

reply = request(hand, struct("cmd", "arm"));
fprintf("arm: %s\n", reply.state);
reply = request(hand, struct("cmd", "target", "finger", finger, "angle_deg", angleDeg));
fprintf("target: %s in %s mode, %g deg\n", strjoin(string(reply.fingers), ", "), reply.mode, ...
        reply.angle_deg);
reply = request(hand, struct("cmd", "start"));
fprintf("start: %s\n", reply.state);
reply = request(hand, struct("cmd", "record_start", "path", recordPath));
fprintf("recording to %s\n", reply.path);

stopAt = tic;
while toc(stopAt) < seconds
    status = request(hand, struct("cmd", "status"));
    f = status.fingers.(finger);
    fprintf("t = %6.2f s  %-8s %s: angle %6.1f deg, pressure %5.1f kPa, force %+.3f N\n", ...
            status.t_s, status.state, finger, f.angle_deg, f.pressure_cmd_kpa, f.force_est_n);
    pause(0.5);
end

reply = request(hand, struct("cmd", "record_stop"));
fprintf("recorded %d rows to %s\n", reply.rows, reply.path);
reply = request(hand, struct("cmd", "disarm"));   % vents every finger
fprintf("disarm: %s\n", reply.state);
clear hand                                         % closes the connection

% load what was recorded: the header, then '#' metadata lines (docs/formats.md 1.4)
T = readtable(recordPath, "CommentStyle", "#");
plot(T.t, T.(['angle_ref_deg_' finger]), T.t, T.(['angle_deg_' finger]));
xlabel("t (s)"); ylabel("angle (deg)"); legend("reference", "measured");


function result = request(hand, message)
% One request, one reply; an error with the daemon's reason if it refuses.
    writeline(hand, jsonencode(message));
    reply = jsondecode(readline(hand));
    if ~reply.ok
        error("hand:refused", "%s: %s", message.cmd, reply.error);
    end
    result = reply.result;
end


function path = defaultTokenFile()
% The token beside the daemon's default socket (hand_service/api/listen.py).
    if ~isempty(getenv("HAND_SERVICE_SOCKET"))
        [folder, name] = fileparts(getenv("HAND_SERVICE_SOCKET"));
        path = fullfile(folder, [name '.token']);
    elseif ~isempty(getenv("XDG_RUNTIME_DIR"))
        path = fullfile(getenv("XDG_RUNTIME_DIR"), "hand-service", "api.token");
    else
        [~, uid] = system("id -u");
        path = fullfile("/tmp", "hand-service-" + strtrim(string(uid)), "api.token");
    end
end
