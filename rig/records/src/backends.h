// The two stores behind OpenStore (store.h).
#ifndef ODOCAL_RECORDS_SRC_BACKENDS_H_
#define ODOCAL_RECORDS_SRC_BACKENDS_H_

#include "odocal/records/store.h"

namespace odocal::records::internal {
Result<std::unique_ptr<RecordStore>> OpenSqliteStore(const std::string& path);
Result<std::unique_ptr<RecordStore>> OpenPostgresStore(const std::string& url);
}  // namespace odocal::records::internal

#endif  // ODOCAL_RECORDS_SRC_BACKENDS_H_
