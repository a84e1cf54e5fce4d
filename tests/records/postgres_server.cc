#include "postgres_server.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <grp.h>
#include <libpq-fe.h>
#include <netinet/in.h>
#include <pwd.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

namespace odocal::records_test {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

constexpr const char* kInstallHint = "bash scripts/install-deps.sh installs them (Debian's postgresql package)";

// The newest /usr/lib/postgresql/N/bin holding the server's programs; empty when none does.
std::string FindBinDir() {
  std::error_code ec;
  std::string best;
  int best_version = -1;
  for (const fs::directory_entry& e : fs::directory_iterator("/usr/lib/postgresql", ec)) {
    const std::string name = e.path().filename().string();
    // "15", "16", "9.6": compare by the major number (then the minor, when there is one).
    char* end = nullptr;
    const long major = std::strtol(name.c_str(), &end, 10);
    if (end == name.c_str()) continue;
    const int version = static_cast<int>(major) * 100 + (*end == '.' ? std::atoi(end + 1) : 0);
    const fs::path bin = e.path() / "bin";
    if (!fs::exists(bin / "initdb", ec) || !fs::exists(bin / "postgres", ec)) continue;
    if (version > best_version) best_version = version, best = bin.string();
  }
  return best;
}

// A port nobody listens on now (the kernel's choice). Another process may take it before the
// server binds it: Launch tries again with another.
Result<int> FreePort() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return Result<int>::Error(StatusCode::kIoError, "socket: " + std::string(strerror(errno)));
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  socklen_t len = sizeof(addr);
  if (bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    const std::string m = strerror(errno);
    close(fd);
    return Result<int>::Error(StatusCode::kIoError, "cannot find a free port on 127.0.0.1: " + m);
  }
  close(fd);
  return Result<int>::Ok(ntohs(addr.sin_port));
}

std::string Tail(const std::string& path, size_t max_chars = 2000) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  std::string text = s.str();
  if (text.size() > max_chars) text = "..." + text.substr(text.size() - max_chars);
  while (!text.empty() && text.back() == '\n') text.pop_back();
  return text;
}

// Starts argv[0] with stdout and stderr appended to `log`, as `as_user` when given. With
// `die_with_us`, it gets SIGQUIT (PostgreSQL's immediate shutdown) when this process dies, so a
// crashed test leaves no server behind.
Result<pid_t> Spawn(const std::vector<std::string>& args, const std::string& log, const passwd* as_user,
                    bool die_with_us) {
  // Everything the child needs is made before fork: between fork and exec only system calls.
  std::vector<char*> argv;
  for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const uid_t uid = as_user ? as_user->pw_uid : 0;
  const gid_t gid = as_user ? as_user->pw_gid : 0;
  const pid_t parent = getpid();
  const pid_t pid = fork();
  if (pid < 0) return Result<pid_t>::Error(StatusCode::kIoError, "fork: " + std::string(strerror(errno)));
  if (pid == 0) {
    const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
    if (fd >= 0) {
      dup2(fd, STDOUT_FILENO);
      dup2(fd, STDERR_FILENO);
    }
    const int null = open("/dev/null", O_RDONLY);
    if (null >= 0) dup2(null, STDIN_FILENO);
    if (as_user) {
      if (setgroups(0, nullptr) != 0 || setgid(gid) != 0 || setuid(uid) != 0) {
        static const char m[] = "postgres_server: cannot become the postgres user\n";
        (void)!write(STDERR_FILENO, m, sizeof(m) - 1);
        _exit(126);
      }
    }
    // After setuid: a change of credentials clears the parent-death signal.
    if (die_with_us) {
      prctl(PR_SET_PDEATHSIG, SIGQUIT);
      if (getppid() != parent) _exit(1);
    }
    execv(argv[0], argv.data());
    _exit(127);
  }
  return Result<pid_t>::Ok(pid);
}

Status RunToEnd(const std::vector<std::string>& args, const std::string& log, const passwd* as_user) {
  Result<pid_t> pid = Spawn(args, log, as_user, /*die_with_us=*/false);
  if (!pid) return Status::From(pid);
  int status = 0;
  while (waitpid(*pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) return Status::Ok();
  return Status::Error(StatusCode::kFailed, args[0] + " failed (" +
                                                (WIFEXITED(status) ? "exit " + std::to_string(WEXITSTATUS(status))
                                                                   : "signal " + std::to_string(WTERMSIG(status))) +
                                                "):\n" + Tail(log));
}

// A connection as the superuser, or the error libpq gave.
Result<PGconn*> Connect(int port, const std::string& db) {
  const std::string info = "host=127.0.0.1 port=" + std::to_string(port) + " user=postgres dbname=" + db + " connect_timeout=5";
  PGconn* conn = PQconnectdb(info.c_str());
  if (PQstatus(conn) != CONNECTION_OK) {
    const std::string m = PQerrorMessage(conn);
    PQfinish(conn);
    return Result<PGconn*>::Error(StatusCode::kOpenFailed, info + ": " + m);
  }
  return Result<PGconn*>::Ok(conn);
}

}  // namespace

Result<std::unique_ptr<PostgresServer>> PostgresServer::Start() {
  using R = Result<std::unique_ptr<PostgresServer>>;
  std::unique_ptr<PostgresServer> server(new PostgresServer());
  server->owner_ = getpid();
  server->bin_dir_ = FindBinDir();
  if (server->bin_dir_.empty())
    return R::Error(StatusCode::kNotFound,
                    std::string("PostgreSQL server programs (initdb, postgres) not found in /usr/lib/postgresql/*/bin: ") +
                        kInstallHint);

  const passwd* as_user = nullptr;
  if (geteuid() == 0) {
    as_user = getpwnam("postgres");
    if (!as_user)
      return R::Error(StatusCode::kNotFound,
                      std::string("running as root, and initdb refuses root, but there is no `postgres` user to run it as: ") +
                          kInstallHint);
  }

  std::string tmpl = (fs::temp_directory_path() / "odocal-pg-XXXXXX").string();
  if (!mkdtemp(tmpl.data())) return R::Error(StatusCode::kIoError, tmpl + ": " + strerror(errno));
  server->dir_ = tmpl;
  if (as_user && chown(tmpl.c_str(), as_user->pw_uid, as_user->pw_gid) != 0)
    return R::Error(StatusCode::kIoError, "chown " + tmpl + " to postgres: " + strerror(errno));

  // --no-sync and (at start) fsync=off: nothing here has to outlive a power cut, and initdb's
  // syncs are most of its time.
  const std::string log = server->dir_ + "/initdb.log";
  if (Status s = RunToEnd({server->bin_dir_ + "/initdb", "-D", server->dir_ + "/data", "-U", "postgres", "-A", "trust",
                           "-E", "UTF8", "--no-locale", "--no-sync", "--no-instructions"},
                          log, as_user);
      !s)
    return R::From(s);
  if (Status s = server->Launch(); !s) return R::From(s);
  return R::Ok(std::move(server));
}

Status PostgresServer::Launch() {
  const passwd* as_user = geteuid() == 0 ? getpwnam("postgres") : nullptr;
  const std::string log = dir_ + "/server.log";
  // The Unix socket's path has a length limit (108 bytes): a long TMPDIR gets TCP only.
  const std::string socket_dir = dir_.size() < 80 ? dir_ : "";
  std::string last_error;
  for (int attempt = 0; attempt < 5; ++attempt) {
    Result<int> port = FreePort();
    if (!port) return Status::From(port);
    Result<pid_t> pid = Spawn({bin_dir_ + "/postgres", "-D", dir_ + "/data", "-p", std::to_string(*port), "-k", socket_dir,
                               "-c", "listen_addresses=127.0.0.1", "-c", "fsync=off", "-c", "synchronous_commit=off",
                               "-c", "full_page_writes=off"},
                              log, as_user, /*die_with_us=*/true);
    if (!pid) return Status::From(pid);
    const std::string info = "host=127.0.0.1 port=" + std::to_string(*port) + " user=postgres dbname=postgres connect_timeout=2";
    const auto deadline = Clock::now() + std::chrono::seconds(30);
    bool exited = false;
    while (Clock::now() < deadline) {
      if (PQping(info.c_str()) == PQPING_OK) {
        port_ = *port;
        pid_ = *pid;
        return Status::Ok();
      }
      int status = 0;
      if (waitpid(*pid, &status, WNOHANG) == *pid) {
        exited = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    last_error = Tail(log);
    if (!exited) {
      kill(*pid, SIGKILL);
      waitpid(*pid, nullptr, 0);
      return Status::Error(StatusCode::kTimeout, "postgres did not answer on port " + std::to_string(*port) +
                                                     " within 30 s:\n" + last_error);
    }
    // Exited: most likely the port was taken in between; anything else fails the same way again.
  }
  return Status::Error(StatusCode::kFailed, "postgres did not start (5 attempts):\n" + last_error);
}

std::string PostgresServer::Url(const std::string& db) const {
  return "postgresql://postgres@127.0.0.1:" + std::to_string(port_) + "/" + db;
}

Result<std::string> PostgresServer::CreateDatabase(const std::string& db) {
  if (Status s = Execute("postgres", "CREATE DATABASE \"" + db + "\""); !s) return Result<std::string>::From(s);
  return Result<std::string>::Ok(Url(db));
}

Status PostgresServer::Execute(const std::string& db, const std::string& sql) {
  Result<PGconn*> conn = Connect(port_, db);
  if (!conn) return Status::From(conn);
  PGresult* r = PQexec(*conn, sql.c_str());
  const ExecStatusType st = PQresultStatus(r);
  Status out = st == PGRES_COMMAND_OK || st == PGRES_TUPLES_OK
                   ? Status::Ok()
                   : Status::Error(StatusCode::kIoError, sql + ": " + PQerrorMessage(*conn));
  PQclear(r);
  PQfinish(*conn);
  return out;
}

PostgresServer::~PostgresServer() { Stop(); }

void PostgresServer::Stop() {
  // A forked test child that leaves by exit() runs its copy of this: the server is not its own.
  if (getpid() != owner_) return;
  if (pid_ > 0) {
    kill(pid_, SIGQUIT);  // immediate shutdown: nothing in the cluster is kept
    const auto deadline = Clock::now() + std::chrono::seconds(10);
    while (waitpid(pid_, nullptr, WNOHANG) == 0) {
      if (Clock::now() > deadline) {
        kill(pid_, SIGKILL);
        waitpid(pid_, nullptr, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    pid_ = -1;
  }
  if (!dir_.empty()) {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    dir_.clear();
  }
}

}  // namespace odocal::records_test
