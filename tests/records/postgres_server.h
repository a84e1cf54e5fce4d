// A real PostgreSQL server for the record store's tests: its own cluster in a fresh temporary
// directory, listening on a free port of 127.0.0.1 with trust authentication, stopped (and the
// directory removed) when the object goes. The newest /usr/lib/postgresql/*/bin is used (Debian's
// layout). initdb and postgres refuse to run as root, and CI runs as root: then they run as the
// `postgres` system user, which owns the directory.
//
//   Result<std::unique_ptr<PostgresServer>> server = PostgresServer::Start();
//   ASSERT_TRUE(server) << server.message;      // binaries missing: says how to install them
//   Result<std::string> url = (*server)->CreateDatabase("round_trip");
//   records::OpenStore(*url);                   // postgresql://postgres@127.0.0.1:PORT/round_trip
#ifndef ODOCAL_TESTS_RECORDS_POSTGRES_SERVER_H_
#define ODOCAL_TESTS_RECORDS_POSTGRES_SERVER_H_

#include <sys/types.h>

#include <memory>
#include <string>

#include "odocal/base/status.h"

namespace odocal::records_test {

class PostgresServer {
 public:
  // initdb (without fsync) and a server started and answering. An error names what is missing
  // or carries what initdb or the server wrote.
  static Result<std::unique_ptr<PostgresServer>> Start();
  ~PostgresServer();
  PostgresServer(const PostgresServer&) = delete;
  PostgresServer& operator=(const PostgresServer&) = delete;

  int port() const { return port_; }
  const std::string& bin_dir() const { return bin_dir_; }
  // postgresql://postgres@127.0.0.1:PORT/DB
  std::string Url(const std::string& db) const;
  // A new, empty database; its URL.
  Result<std::string> CreateDatabase(const std::string& db);
  // One SQL statement on `db` as the superuser (what a test does behind the store's back).
  Status Execute(const std::string& db, const std::string& sql);

 private:
  PostgresServer() = default;
  Status Launch();
  void Stop();

  std::string bin_dir_;
  std::string dir_;   // the temporary directory: data/, the socket, the server's log
  int port_ = 0;
  pid_t pid_ = -1;    // the postmaster, our child
  pid_t owner_ = -1;  // the process that started it (forked test children are not)
};

}  // namespace odocal::records_test

#endif  // ODOCAL_TESTS_RECORDS_POSTGRES_SERVER_H_
