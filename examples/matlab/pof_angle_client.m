% pof_angle_client.m: pofkit's knee angle in MATLAB or GNU Octave, through LCM's Java library.
%
% MATLAB and Octave load Java classes, and LCM's own Java jar (Debian: liblcm-java,
% /usr/share/java/lcm.jar) decodes the bus; pofkit installs its message classes as
% <prefix>/share/java/pof_lcmtypes.jar (the .deb: /usr/share/java/pof_lcmtypes.jar).
% Like examples/cpp_client/angle_client.cpp it checks sequence gaps, the quality flags and the
% sample age (receive time minus angle_t.utime, the host time of the scan).
%
%   pof_angle_client()                        % POF_ANGLE, $LCM_DEFAULT_URL, 200 angles
%   pof_angle_client('POF_ANGLE_LEFT_KNEE', 500, 'udpm://239.255.76.67:7667?ttl=0')
%
% Octave needs its Java support (Debian's octave package has it) and LCM_DEFAULT_URL or the URL.
% The second output is the LCM instance, still subscribed: close it with lc.close() when done.
function [stats, lc] = pof_angle_client(channel, count, url, jardir)
  if nargin < 1 || isempty(channel), channel = 'POF_ANGLE'; end
  if nargin < 2 || isempty(count), count = 200; end
  if nargin < 3, url = ''; end
  if nargin < 4 || isempty(jardir), jardir = '/usr/share/java'; end
  javaaddpath('/usr/share/java/lcm.jar');
  javaaddpath(fullfile(jardir, 'pof_lcmtypes.jar'));

  if isempty(url)
    lc = javaObject('lcm.lcm.LCM');            % $LCM_DEFAULT_URL, else LCM's default
  else
    lc = javaObject('lcm.lcm.LCM', {url});
  end
  agg = javaObject('lcm.lcm.MessageAggregator');
  agg.setMaxMessages(10000);                   % the queue a 200 Hz stream needs between polls
  lc.subscribe(channel, agg);

  stats = struct('angles', 0, 'lost', 0, 'undecodable', 0, 'unusable', 0, 'flagged', 0, 'age_ms', []);
  last_seq = -1;
  QUALITY_INVALID_INPUT = 4;                   % angle_t.QUALITY_INVALID_INPUT: the angle is NaN
  while stats.angles < count
    msg = agg.getNextMessage(5000);            % ms
    if isempty(msg), break; end
    % The receive time in us (java.time.Instant: microseconds on Linux; currentTimeMillis would round
    % every age to a whole ms). javaMethod: Octave lacks java.* dot calls.
    t = javaMethod('now', 'java.time.Instant');
    now_us = double(t.getEpochSecond()) * 1e6 + double(t.getNano()) / 1e3;
    try
      a = javaObject('pof.angle_t', msg.data);  % throws on a malformed message: count, skip
    catch
      stats.undecodable = stats.undecodable + 1;
      continue;
    end
    seq = double(a.seq);
    if last_seq >= 0 && seq > last_seq + 1, stats.lost = stats.lost + seq - last_seq - 1; end
    last_seq = seq;
    stats.angles = stats.angles + 1;
    if bitand(double(a.quality), QUALITY_INVALID_INPUT) || ~isfinite(double(a.angle_deg))
      stats.unusable = stats.unusable + 1;
    elseif a.quality ~= 0
      stats.flagged = stats.flagged + 1;
    end
    stats.age_ms(end + 1) = (now_us - double(a.utime)) / 1e3;
  end
  % Unsubscribed, not closed: LCM's Java close() makes its receive thread print a SocketException
  % (it was blocked in the socket close() shuts). The caller closes lc when it is done with it.
  lc.unsubscribe(channel, agg);
  ages = sort(stats.age_ms);
  p99 = NaN;
  if ~isempty(ages), p99 = ages(max(1, ceil(0.99 * numel(ages)))); end
  fprintf('summary: angles=%d lost=%d undecodable=%d unusable=%d flagged=%d age_p50_ms=%.3f age_p99_ms=%.3f age_max_ms=%.3f\n', ...
          stats.angles, stats.lost, stats.undecodable, stats.unusable, stats.flagged, median(ages), p99, max([ages, NaN]));
end
